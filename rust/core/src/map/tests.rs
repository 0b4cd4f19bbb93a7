//! Unit and property tests of the floor map on tiny hand-built plans.

use super::*;
use proptest::prelude::*;

/// 20 x 10 px at r = 1: a wall border, a 2-px vertical wall at columns 10-11
/// with a door in rows 4-5 (MCS y in (4, 6]); room A left, room B right.
fn two_rooms() -> FloorMap {
    let (w, h) = (20usize, 10usize);
    let mut f = vec![Feature::Walkable; w * h];
    for j in 0..h {
        for i in 0..w {
            let border = i == 0 || j == 0 || i == w - 1 || j == h - 1;
            if border || i == 10 || i == 11 {
                f[j * w + i] = Feature::Wall;
            }
        }
    }
    for j in 4..6 {
        f[j * w + 10] = Feature::Door;
        f[j * w + 11] = Feature::Door;
    }
    FloorMap::from_features(w, h, 1.0, f)
}

/// 30 x 30 px at r = 1 with a wall band |i - j| <= 1 (ICS), i.e. the MCS line
/// x + y = 30, plus a border.
fn diagonal() -> FloorMap {
    let n = 30usize;
    let mut f = vec![Feature::Walkable; n * n];
    for j in 0..n {
        for i in 0..n {
            let border = i == 0 || j == 0 || i == n - 1 || j == n - 1;
            if border || (i as isize - j as isize).abs() <= 1 {
                f[j * n + i] = Feature::Wall;
            }
        }
    }
    FloorMap::from_features(n, n, 1.0, f)
}

fn v(x: f64, y: f64) -> Vec2 {
    Vec2::new(x, y)
}

#[test]
fn raycast_hits_door_and_wall_where_expected() {
    let m = two_rooms();
    // MCS y = 5.0 -> ICS row 5 (door rows 4-5).
    let hit = m
        .raycast(v(5.0, 5.0), v(15.0, 5.0), 0.05)
        .expect("door hit");
    assert_eq!(hit.feature, Feature::Door);
    assert!(
        hit.point.x >= 10.0 && hit.point.x < 10.05 + 1e-9,
        "{:?}",
        hit.point
    );
    // MCS y = 8.0 -> ICS row 2: wall.
    let hit = m
        .raycast(v(5.0, 8.0), v(15.0, 8.0), 0.05)
        .expect("wall hit");
    assert_eq!(hit.feature, Feature::Wall);
    assert!((hit.point.x - 10.0).abs() < 0.05 + 1e-9);
    // Inside room A: no hit.
    assert!(m.raycast(v(2.0, 2.0), v(8.0, 8.0), 0.05).is_none());
    // Zero-length ray tests the start point alone.
    assert!(m.raycast(v(5.0, 5.0), v(5.0, 5.0), 0.05).is_none());
    assert!(m.raycast(v(10.5, 5.0), v(10.5, 5.0), 0.05).is_some());
    // Outside the image is Wall.
    assert_eq!(m.feature(v(-1.0, 5.0)), Feature::Wall);
    assert_eq!(m.m_value(v(10.5, 5.0)), 0.5);
}

#[test]
fn room_of_is_right_on_both_sides_of_a_door() {
    let m = two_rooms();
    assert_eq!(m.rooms().len(), 2);
    let a = m.room_of(v(9.5, 5.0)).expect("room A");
    let b = m.room_of(v(12.5, 5.0)).expect("room B");
    assert_ne!(a, b);
    assert_eq!(m.room_of(v(1.5, 1.5)), Some(a));
    assert_eq!(m.room_of(v(18.5, 8.5)), Some(b));
    assert_eq!(m.room_of(v(10.5, 5.0)), None, "door pixel is no room");
    assert_eq!(m.room_of(v(-3.0, 5.0)), None);
    // Room A: columns 1..=9, rows 1..=8 -> 72 px = 72 m^2 at r = 1.
    let ra = &m.rooms()[a as usize];
    assert_eq!(ra.pixel_count, 72);
    assert!((ra.area_m2 - 72.0).abs() < 1e-9);
    assert!(
        (ra.centroid_m - v(5.5, 5.0)).norm() < 1e-9,
        "{:?}",
        ra.centroid_m
    );
    assert_eq!(m.door_pixel_count(), 4);
    assert!((m.walkable_area_m2() - (72.0 + 56.0)).abs() < 1e-9);
}

#[test]
fn normals_point_out_of_the_obstacle() {
    let m = two_rooms();
    let from_left = m.raycast(v(5.0, 5.0), v(15.0, 5.0), 0.05).unwrap();
    let n = m.normal_at(from_left.point).expect("normal");
    assert!(n.dot(&v(-1.0, 0.0)) > 0.99, "{n:?}");
    let from_right = m.raycast(v(15.0, 5.0), v(5.0, 5.0), 0.05).unwrap();
    let n = m.normal_at(from_right.point).expect("normal");
    assert!(n.dot(&v(1.0, 0.0)) > 0.99, "{n:?}");
    // Bottom border (ICS row 9): the normal points up in the MCS (y flip).
    let n = m.normal_at(v(5.5, 0.5)).expect("normal");
    assert!(n.dot(&v(0.0, 1.0)) > 0.99, "{n:?}");
    // Top border: down.
    let n = m.normal_at(v(5.5, 9.5)).expect("normal");
    assert!(n.dot(&v(0.0, -1.0)) > 0.99, "{n:?}");
    // Open space: the gradient vanishes.
    assert!(m.normal_at(v(5.5, 5.5)).is_none());
    // Unit length.
    assert!((m.normal_at(v(10.2, 5.0)).unwrap().norm() - 1.0).abs() < 1e-12);
}

#[test]
fn diagonal_wall_blocks_rays_and_has_a_diagonal_normal() {
    let m = diagonal();
    let lo = m.room_of(v(5.0, 5.0)).expect("lower-left room");
    let hi = m.room_of(v(25.0, 25.0)).expect("upper-right room");
    assert_ne!(lo, hi);
    let hit = m.raycast(v(5.0, 5.0), v(25.0, 25.0), 0.05).expect("hit");
    assert_eq!(hit.feature, Feature::Wall);
    // Band |i - j| <= 1 around x + y = 30: first contact before the centre line.
    assert!(hit.point.x > 13.0 && hit.point.x < 15.0, "{:?}", hit.point);
    let n = m.normal_at(hit.point).expect("normal");
    let want = v(-1.0, -1.0) / 2f64.sqrt();
    assert!(n.dot(&want) > 0.9, "{n:?}");
    let hit = m.raycast(v(25.0, 25.0), v(5.0, 5.0), 0.05).expect("hit");
    let n = m.normal_at(hit.point).expect("normal");
    assert!(n.dot(&-want) > 0.9, "{n:?}");
    // A ray parallel to the wall does not hit it.
    assert!(m.raycast(v(3.0, 20.0), v(20.0, 3.0), 0.05).is_none());
}

#[test]
fn nearest_walkable_in_room_finds_the_other_side() {
    let m = two_rooms();
    let a = m.room_of(v(5.0, 5.0)).unwrap();
    let b = m.room_of(v(15.0, 5.0)).unwrap();
    let p = m.nearest_walkable_in_room(b, v(10.5, 5.0)).unwrap();
    assert_eq!(m.room_of(p), Some(b));
    assert!(
        (p - v(12.5, 4.5)).norm() < 1e-9 || (p - v(12.5, 5.5)).norm() < 1e-9,
        "{p:?}"
    );
    // A point already in the room is its own answer.
    assert_eq!(
        m.nearest_walkable_in_room(a, v(5.0, 5.0)),
        Some(v(5.0, 5.0))
    );
    assert_eq!(m.nearest_walkable_in_room(99, v(5.0, 5.0)), None);
}

#[test]
fn grid_holds_walkable_cell_centres_only() {
    let m = two_rooms();
    assert_eq!(m.grid_interval_m(), 1.0);
    // At r = 1 and I_M = 1 every walkable pixel centre is a grid point.
    assert_eq!(m.grid().len(), m.walkable_pixel_count());
    assert!(m.grid().iter().all(|&g| m.is_walkable(g)));
    assert!(m.grid().contains(&v(1.5, 1.5)));
    let coarse = FloorMap::from_features_with_grid(20, 10, 1.0, two_rooms().features.clone(), 2.0);
    // Cell centres (2i + 1, 2j + 1): i in 0..10, j in 0..5, minus obstacles.
    assert!(
        coarse
            .grid()
            .iter()
            .all(|g| g.x % 2.0 == 1.0 && g.y % 2.0 == 1.0)
    );
    assert!(coarse.grid().iter().all(|&g| coarse.is_walkable(g)));
    assert!(!coarse.grid().is_empty());
    let none = FloorMap::from_features_with_grid(20, 10, 1.0, two_rooms().features.clone(), 0.0);
    assert!(none.grid().is_empty());
}

#[test]
fn downsampled_plan_keeps_walls_and_frames() {
    let img = two_rooms();
    let plan = ClassifiedPlan {
        width_px: 20,
        height_px: 10,
        features: img.features.clone(),
        unclassified_count: 3,
    };
    let m = FloorMap::from_classified_plan(plan, 2.0, 2, 1.0);
    assert_eq!((m.width_px(), m.height_px()), (10, 5));
    assert_eq!(m.pixels_per_meter(), 1.0);
    assert_eq!(m.build_report().downsample_factor, 2);
    assert_eq!(m.build_report().unclassified_count, 3);
    // Same metric size; the separating wall is still there.
    assert_eq!((m.width_m(), m.height_m()), (10.0, 5.0));
    let hit = m
        .raycast(v(2.0, 3.7), v(8.0, 3.7), 0.05)
        .expect("wall kept");
    assert_eq!(hit.feature, Feature::Wall);
    assert!(
        hit.point.x >= 5.0 && hit.point.x < 5.05 + 1e-9,
        "{:?}",
        hit.point
    );
    let hit = m
        .raycast(v(2.0, 2.5), v(8.0, 2.5), 0.05)
        .expect("door kept");
    assert_eq!(hit.feature, Feature::Door);
}

proptest! {
    #[test]
    fn ics_mcs_round_trip(x in -50.0f64..150.0, y in -50.0f64..150.0, r in 0.5f64..40.0) {
        let m = FloorMap::from_features(7, 5, r, vec![Feature::Walkable; 35]);
        let p = v(x, y);
        let back = m.ics_to_mcs(m.mcs_to_ics(p));
        prop_assert!((back - p).norm() < 1e-9 * (1.0 + p.norm()));
        let q = v(x * r, y * r);
        let back = m.mcs_to_ics(m.ics_to_mcs(q));
        prop_assert!((back - q).norm() < 1e-9 * (1.0 + q.norm()));
        // The pixel of a point contains its ICS image.
        if let Some((i, j)) = m.pixel_of(p) {
            let q = m.mcs_to_ics(p);
            prop_assert!(q.x >= i as f64 && q.x < i as f64 + 1.0);
            prop_assert!(q.y >= j as f64 && q.y < j as f64 + 1.0);
        }
    }

    #[test]
    fn raycast_never_hits_beyond_its_end(
        x1 in -2.0f64..32.0, y1 in -2.0f64..32.0,
        x2 in -2.0f64..32.0, y2 in -2.0f64..32.0,
        step in 0.01f64..1.0,
    ) {
        let m = diagonal();
        let (a, b) = (v(x1, y1), v(x2, y2));
        if let Some(hit) = m.raycast(a, b, step) {
            let len = (b - a).norm();
            let s = (hit.point - a).norm();
            prop_assert!(s <= len + 1e-9, "hit {s} beyond end {len}");
            // On the segment.
            if len > 0.0 {
                let t = (hit.point - a).dot(&(b - a)) / (len * len);
                prop_assert!(((a + (b - a) * t) - hit.point).norm() < 1e-9);
            }
            prop_assert!(m.feature(hit.point).is_obstacle());
            prop_assert_eq!(m.feature(hit.point), hit.feature);
        }
    }
}

/// The committed demo map (maps/demo), built from its bytes.
fn demo() -> &'static FloorMap {
    use std::sync::OnceLock;
    static MAP: OnceLock<FloorMap> = OnceLock::new();
    MAP.get_or_init(|| {
        let png = include_bytes!("../../../../maps/demo/plan.png");
        let plan = classify_png(png, &super::Legend::default(), "plan.png").unwrap();
        FloorMap::from_classified_plan(plan, 10.0, 1, 1.0)
    })
}

#[test]
fn demo_map_has_rooms_doors_and_grid() {
    let m = demo();
    assert_eq!((m.width_m(), m.height_m()), (64.0, 44.0));
    assert_eq!(m.build_report().unclassified_count, 0);
    assert!(m.rooms().len() >= 9, "{}", m.rooms().len());
    assert!(m.door_pixel_count() > 0);
    // Both sides of the door in the diagonal wall are different rooms, and the
    // curved wall separates the corner room.
    assert_ne!(m.room_of(v(5.0, 10.0)), m.room_of(v(25.0, 10.0)));
    assert_ne!(m.room_of(v(60.0, 40.0)), m.room_of(v(50.0, 30.0)));
    assert!(m.grid().len() > 2000);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]
    /// Rooms are separated by obstacles that a 0.05 m raycast never jumps:
    /// a ray between two different rooms always hits.
    #[test]
    fn demo_rays_between_rooms_always_hit(
        x1 in 0.0f64..64.0, y1 in 0.0f64..44.0, x2 in 0.0f64..64.0, y2 in 0.0f64..44.0,
    ) {
        let m = demo();
        let (a, b) = (v(x1, y1), v(x2, y2));
        if let (Some(ra), Some(rb)) = (m.room_of(a), m.room_of(b)) {
            let hit = m.raycast(a, b, 0.05);
            if ra != rb {
                prop_assert!(hit.is_some(), "ray {a:?} -> {b:?} crossed rooms {ra} -> {rb}");
            }
        }
    }
}

#[test]
fn nearest_walkable_within_finds_the_closest_pixel_or_none() {
    let m = two_rooms();
    // a walkable point is itself
    assert_eq!(
        m.nearest_walkable_within(v(5.5, 5.5), 3.0),
        Some(v(5.5, 5.5))
    );
    // in the 2-px wall (x in [10, 12)), off the door rows: the nearest
    // walkable pixel centre is the one left of it (x 9.5) or right (12.5)
    let p = m.nearest_walkable_within(v(10.4, 8.5), 3.0).unwrap();
    assert!(m.is_walkable(p));
    assert!((p - v(9.5, 8.5)).norm() < 1e-9, "{p:?}");
    let q = m.nearest_walkable_within(v(11.7, 8.5), 3.0).unwrap();
    assert!((q - v(12.5, 8.5)).norm() < 1e-9, "{q:?}");
    // too small a radius, a zero radius, NaN, far outside: none
    assert_eq!(m.nearest_walkable_within(v(10.4, 8.5), 0.5), None);
    assert_eq!(m.nearest_walkable_within(v(10.4, 8.5), 0.0), None);
    assert_eq!(m.nearest_walkable_within(v(f64::NAN, 8.5), 3.0), None);
    assert_eq!(m.nearest_walkable_within(v(500.0, -500.0), 3.0), None);
    // just outside the plan: the border is wall, the first walkable
    // pixel is 1.5 m in
    assert_eq!(m.nearest_walkable_within(v(-0.5, 5.5), 1.5), None);
    assert!(m.nearest_walkable_within(v(-0.5, 5.5), 2.5).is_some());
}
