//! A tiny engine and an open-floor site for harness tests.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use fpbp_core::engine::{Engine, InitialPosition, Task};
use fpbp_core::engine::{EngineStats, Pose};
use fpbp_core::engines::EngineConfig;
use fpbp_core::events::LogEvent;
use fpbp_core::events::{BleObservation, SensorEvent};
use fpbp_core::map::{Feature, FloorMap};
use fpbp_core::site::Site;
use fpbp_core::site::SiteSpec;

/// Moves east at 1 m/s from its start (or has no fix without one); one fusion
/// task every 100 ms.
pub struct WalkEast {
    pub start: Option<InitialPosition>,
    pub t0: Option<i64>,
    pub pose: Option<Pose>,
    pub stats: EngineStats,
}

impl Engine for WalkEast {
    fn name(&self) -> &'static str {
        "walk-east"
    }
    fn on_sensor(&mut self, e: &SensorEvent) {
        self.stats.sensor_events += 1;
        self.t0.get_or_insert(e.t_ns);
    }
    fn on_ble(&mut self, _obs: &BleObservation) {
        self.stats.ble_observations += 1;
    }
    fn run_task(&mut self, _task: Task, t_ns: i64) {
        let (Some(s), Some(t0)) = (self.start, self.t0) else {
            self.stats.no_fix += 1;
            return;
        };
        let d = (t_ns - t0) as f64 * 1e-9;
        self.pose = Some(Pose {
            t_ns,
            x_m: s.x_m + d,
            y_m: s.y_m,
            floor: s.floor,
            heading_rad: 0.0,
            accuracy_m: 1.0,
            floor_prob: 1.0,
            source: fpbp_core::engine::PoseSource::Fused,
        });
    }
    fn task_period_ns(&self, task: Task) -> Option<i64> {
        (task == Task::Fusion).then_some(100_000_000)
    }
    fn pose(&self) -> Option<Pose> {
        self.pose
    }
    fn stats(&self) -> EngineStats {
        self.stats.clone()
    }
}

pub fn builder(
    name: &str,
    _site: Arc<Site>,
    _cfg: &EngineConfig,
    init: Option<InitialPosition>,
) -> anyhow::Result<Box<dyn Engine>> {
    match name {
        "pdr" | "walk-east" => Ok(Box::new(WalkEast {
            start: init,
            t0: None,
            pose: None,
            stats: EngineStats::default(),
        })),
        other => anyhow::bail!("unknown engine `{other}`"),
    }
}

/// A 30 x 10 m open floor (id 0) at 2 px/m.
pub fn site() -> Arc<Site> {
    let spec: SiteSpec = serde_json::from_str(
        r#"{"format":"fpbp-site","version":1,"name":"test","floors":[{"id":0,"open_area_m":[30,10]}]}"#,
    )
    .unwrap();
    let (w, h) = (60, 20);
    let f = (0..w * h)
        .map(|k| {
            let (i, j) = (k % w, k / w);
            if i == 0 || j == 0 || i == w - 1 || j == h - 1 {
                Feature::Wall
            } else {
                Feature::Walkable
            }
        })
        .collect();
    Arc::new(Site {
        spec,
        floors: vec![FloorMap::from_features(w, h, 2.0, f)],
    })
}

/// A native log: accelerometer at 50 Hz for `secs`, truth every second along y = 5
/// moving east at 1 m/s from x = 2.
pub fn write_log(path: &Path, secs: i64) {
    use fpbp_core::events::{SensorData, TruthPoint};
    let mut w = fpbp_logs::NativeWriter::new(
        std::fs::File::create(path).unwrap(),
        &fpbp_logs::NativeHeader::new().with("test", "1"),
    )
    .unwrap();
    for k in 0..secs * 50 {
        let t = k * 20_000_000;
        w.write(&LogEvent::Sensor(SensorEvent {
            t_ns: t,
            data: SensorData::Accelerometer([0.0, 0.0, 9.8]),
        }))
        .unwrap();
        if k % 50 == 0 {
            let s = (k / 50) as f64;
            w.write(&LogEvent::Truth(TruthPoint {
                t_ns: t,
                x_m: 2.0 + s,
                y_m: 5.0,
                floor: None,
            }))
            .unwrap();
        }
    }
    w.finish().unwrap();
}

pub fn tmp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("fpbp-cli-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}
