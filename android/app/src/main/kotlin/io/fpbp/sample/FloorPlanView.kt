package io.fpbp.sample

import android.content.Context
import android.graphics.Bitmap
import android.graphics.Canvas
import android.graphics.Color
import android.graphics.Matrix
import android.graphics.Paint
import android.view.MotionEvent
import android.view.View
import io.fpbp.Pose
import io.fpbp.SurveyMark
import kotlin.math.cos
import kotlin.math.min
import kotlin.math.sin

/**
 * Draws one floor's stylized plan scaled to fit, the live pose as a dot with
 * a heading tick and its accuracy circle when the pose is on that floor.
 * Map frame (MCS, metres, y up) to plan pixels (ICS, y down): x_I = x r,
 * y_I = H - y r (FP-BP eq. 23), then the view's fit transform. A tap reports
 * the MCS point under the finger. In a survey it also draws the waypoint
 * marks of the shown floor and the walked track between consecutive marks
 * (the straight lines `fpbp calibrate` places the readings on).
 */
class FloorPlanView(context: Context) : View(context) {
    private var plan: Bitmap? = null
    private var pixelsPerMeter = 1.0

    /** The floor whose plan is shown (site.json id). */
    var floorId: Int = 0
        private set

    /** Whether the last pose was drawn (it is on [floorId]). */
    val poseDrawn: Boolean get() = pose?.floor == floorId
    private var pose: Pose? = null
    private var blePosition: Pose? = null
    private val fit = Matrix()
    private val inverse = Matrix()

    /** Called with (x_m, y_m) of a tap on the plan. */
    var onTap: ((Double, Double) -> Unit)? = null

    private val dot = Paint(Paint.ANTI_ALIAS_FLAG).apply { color = Color.rgb(25, 118, 210) }
    private val bleDot = Paint(Paint.ANTI_ALIAS_FLAG).apply { color = Color.rgb(255, 143, 0) }
    private val circle = Paint(Paint.ANTI_ALIAS_FLAG).apply {
        color = Color.argb(60, 25, 118, 210)
        style = Paint.Style.FILL
    }
    private val ring = Paint(Paint.ANTI_ALIAS_FLAG).apply {
        color = Color.rgb(25, 118, 210)
        style = Paint.Style.STROKE
        strokeWidth = 3f
    }

    private var marks: List<SurveyMark> = emptyList()
    private val trackPaint = Paint(Paint.ANTI_ALIAS_FLAG).apply {
        color = Color.rgb(46, 125, 50)
        style = Paint.Style.STROKE
        strokeWidth = 4f
    }
    private val markPaint = Paint(Paint.ANTI_ALIAS_FLAG).apply { color = Color.rgb(46, 125, 50) }
    private val lastMarkPaint = Paint(Paint.ANTI_ALIAS_FLAG).apply { color = Color.rgb(198, 40, 40) }

    /** Marks drawn on the shown floor (in order; the last one highlighted). */
    val marksDrawn: Int get() = marks.count { it.floor == floorId }

    /** Updates the survey's waypoint marks (the walked track); call on the UI thread. */
    fun setMarks(marks: List<SurveyMark>) {
        this.marks = marks
        invalidate()
    }

    /** Shows [bitmap], the plan of [floor] at [pixelsPerMeter] pixels per metre. */
    fun setPlan(floor: Int, bitmap: Bitmap?, pixelsPerMeter: Double) {
        floorId = floor
        plan = bitmap
        this.pixelsPerMeter = pixelsPerMeter
        requestLayout()
        invalidate()
    }

    /** Updates the pose (and the BLE-only position x_B); call on the UI thread. */
    fun setPose(pose: Pose?, blePosition: Pose?) {
        this.pose = pose
        this.blePosition = blePosition
        invalidate()
    }

    private fun toPlanPx(xM: Double, yM: Double): FloatArray {
        val h = plan?.height ?: 0
        val pts = floatArrayOf((xM * pixelsPerMeter).toFloat(), (h - yM * pixelsPerMeter).toFloat())
        fit.mapPoints(pts)
        return pts
    }

    override fun onDraw(canvas: Canvas) {
        super.onDraw(canvas)
        canvas.drawColor(Color.LTGRAY)
        val bmp = plan ?: return
        val s = min(width.toFloat() / bmp.width, height.toFloat() / bmp.height)
        fit.reset()
        fit.postScale(s, s)
        fit.postTranslate((width - bmp.width * s) / 2f, (height - bmp.height * s) / 2f)
        fit.invert(inverse)
        canvas.drawBitmap(bmp, fit, null)
        drawMarks(canvas)
        blePosition?.takeIf { it.floor == floorId }?.let { b ->
            val p = toPlanPx(b.xM, b.yM)
            canvas.drawCircle(p[0], p[1], 8f, bleDot)
        }
        val p = pose?.takeIf { it.floor == floorId } ?: return
        val c = toPlanPx(p.xM, p.yM)
        val r = (p.accuracyM * pixelsPerMeter * s).toFloat()
        canvas.drawCircle(c[0], c[1], r, circle)
        canvas.drawCircle(c[0], c[1], r, ring)
        canvas.drawCircle(c[0], c[1], 12f, dot)
        // Heading: MCS angle, y up; the screen's y is down.
        val len = 36f
        canvas.drawLine(c[0], c[1], c[0] + len * cos(p.headingRad).toFloat(), c[1] - len * sin(p.headingRad).toFloat(), ring)
    }

    private fun drawMarks(canvas: Canvas) {
        var prev: SurveyMark? = null
        for (m in marks) {
            val p = prev
            if (p != null && p.floor == floorId && m.floor == floorId) {
                val a = toPlanPx(p.xM, p.yM)
                val b = toPlanPx(m.xM, m.yM)
                canvas.drawLine(a[0], a[1], b[0], b[1], trackPaint)
            }
            prev = m
        }
        val last = marks.lastOrNull()
        for (m in marks) {
            if (m.floor != floorId) continue
            val c = toPlanPx(m.xM, m.yM)
            canvas.drawCircle(c[0], c[1], if (m === last) 10f else 6f, if (m === last) lastMarkPaint else markPaint)
        }
    }

    override fun onTouchEvent(event: MotionEvent): Boolean {
        val bmp = plan
        if (event.action != MotionEvent.ACTION_UP || bmp == null) return true
        val pts = floatArrayOf(event.x, event.y)
        inverse.mapPoints(pts)
        onTap?.invoke(pts[0] / pixelsPerMeter, (bmp.height - pts[1]) / pixelsPerMeter)
        performClick()
        return true
    }

    override fun performClick(): Boolean = super.performClick()
}
