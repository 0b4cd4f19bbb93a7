//! Tests of the IPIN importer (`super::ipin`).

use super::*;
use fpbp_core::geo::wgs84_from_mcs;

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("fpbp-import-ipin-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

const CAL: &str = "% comment\n%\nMap_0.png Map_-1.png\n0 -1\n100 100\n49.0 49.0\n11.0 11.0\n-30.0 -30.0\n0.1 0.1\n";

#[test]
fn parses_cal_and_rejects_bad_columns() {
    let c = parse_cal(CAL, "t.cal").unwrap();
    assert_eq!(c.len(), 2);
    assert_eq!(
        (c[1].image.as_str(), c[1].floor, c[1].rotation_deg),
        ("Map_-1.png", -1, -30.0)
    );
    let bad = CAL.replace("0.1 0.1", "0.1");
    assert!(format!("{:#}", parse_cal(&bad, "t.cal").unwrap_err()).contains("line 9"));
    let bad = CAL.replace("11.0 11.0", "11.0 east");
    assert!(format!("{:#}", parse_cal(&bad, "t.cal").unwrap_err()).contains("`east`"));
}

#[test]
fn minor_mapping_swaps_2_and_3() {
    let m: Vec<_> = (1..=6)
        .map(|n| minor_of(&format!("BLE{n}")).unwrap())
        .collect();
    assert_eq!(m, vec![1, 3, 2, 4, 5, 6]);
    assert_eq!(minor_of("X7"), None);
    assert_eq!(
        beacon_id(2),
        "ibeacon:11111111-1111-BEAC-2023-111111111111:1:2"
    );
}

/// A two-beacon CSV, a .cal with a known georeference, one drawn image
/// (floor -1) and one log visiting both floors.
#[test]
fn imports_a_synthetic_dataset() {
    let dir = tmp("synthetic");
    std::fs::create_dir_all(dir.join("maps")).unwrap();
    std::fs::create_dir_all(dir.join("logs")).unwrap();
    std::fs::write(dir.join("maps/site.cal"), CAL).unwrap();
    // 200 x 100 px at 0.1 m/px = 20 x 10 m; a drawn block at px x 50..90, y 20..60,
    // i.e. MCS x 5..9 m, y 4..8 m.
    let mut img = image::RgbaImage::from_pixel(200, 100, image::Rgba([255, 255, 255, 255]));
    for v in 20..60 {
        for u in [50, 89] {
            img.put_pixel(u, v, image::Rgba([0, 0, 0, 255]));
        }
    }
    for u in 50..90 {
        for v in [20, 59] {
            img.put_pixel(u, v, image::Rgba([0, 0, 0, 255]));
        }
    }
    img.save(dir.join("maps/Map_-1.png")).unwrap();
    // Georef: image centre (10, 5) m at (49, 11); ENU -> MCS rotation -30 deg.
    let g = GeoRef {
        lat_deg: 49.0,
        lon_deg: 11.0,
        x_m: 10.0,
        y_m: 5.0,
    };
    let rot = (-30.0f64).to_radians();
    let north5 = fpbp_core::geo::wgs84_from_enu(49.0, 11.0, Vec2::new(0.0, 5.0));
    std::fs::write(
        dir.join("BLE_Locations.csv"),
        format!(
            "bleID,Lat,Lon,floor\n\"BLE1\",49.0,11.0,00\n\"BLE3\",{},{},-1\n",
            north5.0, north5.1
        ),
    )
    .unwrap();
    let (la, lo) = wgs84_from_mcs(&g, rot, Vec2::new(7.0, 6.0));
    let log = format!(
        "% header\nPRES;9.8;1;1000.0;3\nPRES;10.2;1;1000.0;3\nPOSI;10.0;1;49.0;11.0;0;100\n\
         PRES;19.8;1;1000.5;3\nPRES;20.2;1;1000.5;3\nPOSI;20.0;2;{la};{lo};-1;100\n"
    );
    std::fs::write(dir.join("logs/trial.txt"), log).unwrap();
    let out = dir.join("site");
    let rep = import(&IpinImport {
        dataset_dir: dir.clone(),
        out: out.clone(),
        pixels_per_meter: 10.0,
        open_margin_m: 3.0,
    })
    .unwrap();
    assert!((rep.width_m - 20.0).abs() < 1e-9 && (rep.height_m - 10.0).abs() < 1e-9);
    // Beacons: BLE1 at the centre, BLE3 5 m north = R(-30 deg)[0, 5] from it, minor 2.
    let b1 = &rep.beacons[0];
    assert!(
        (b1.x_m - 10.0).abs() < 1e-6 && (b1.y_m - 5.0).abs() < 1e-6,
        "{b1:?}"
    );
    let b3 = &rep.beacons[1];
    assert!(b3.id.ends_with(":1:2") && b3.floor == -1);
    let want = Vec2::new(10.0 + 5.0 * 0.5, 5.0 + 5.0 * 3f64.sqrt() / 2.0);
    assert!((Vec2::new(b3.x_m, b3.y_m) - want).norm() < 1e-6, "{b3:?}");
    // Heights from the 0.5 hPa step: H ln(1000 / 1000.5) = -4.2 m.
    let f0 = rep.floors.iter().find(|f| f.id == 0).unwrap();
    let fm1 = rep.floors.iter().find(|f| f.id == -1).unwrap();
    assert_eq!(f0.height_m, 0.0);
    assert!((fm1.height_m - SCALE_HEIGHT_M * (1000.0f64 / 1000.5).ln()).abs() < 1e-9);
    assert!((fm1.height_m + 4.2).abs() < 0.05);
    assert_eq!((f0.source.as_str(), fm1.source.as_str()), ("open", "image"));
    // Truth lands on walkable pixels of both floors.
    assert_eq!((f0.truth_walkable, fm1.truth_walkable), (1, 1));
    // The site file round-trips and the plans have the expected extents.
    let spec: SiteSpec =
        serde_json::from_str(&std::fs::read_to_string(out.join("site.json")).unwrap()).unwrap();
    assert!((spec.map_from_enu_rad - rot).abs() < 1e-12);
    assert_eq!(spec.georef, Some(g));
    let grid = Grid::covering(20.0, 10.0, 10.0);
    let plan = |f: &str| -> FloorMapT {
        let img = image::open(out.join(f)).unwrap().to_rgb8();
        let feats = img
            .pixels()
            .map(|p| {
                if p.0 == [255, 255, 255] {
                    Feature::Walkable
                } else {
                    Feature::Wall
                }
            })
            .collect();
        floor_map(&grid, feats)
    };
    // Floor -1: the drawing's bbox (5..9 x 4..8) + 1 m is walkable, the rest wall.
    let m1 = plan("plan_-1.png");
    assert!(m1.is_walkable(Vec2::new(4.3, 3.3)) && m1.is_walkable(Vec2::new(9.7, 8.7)));
    assert!(!m1.is_walkable(Vec2::new(3.7, 5.0)) && !m1.is_walkable(Vec2::new(12.0, 5.0)));
    // Floor 0: bbox of the truth and beacon (10, 5) + 3 m.
    let m0 = plan("plan_0.png");
    assert!(m0.is_walkable(Vec2::new(7.2, 2.2)) && m0.is_walkable(Vec2::new(12.8, 7.8)));
    assert!(!m0.is_walkable(Vec2::new(6.7, 5.0)) && !m0.is_walkable(Vec2::new(10.0, 8.3)));
    std::fs::remove_dir_all(&dir).ok();
}

type FloorMapT = fpbp_core::map::FloorMap;

/// The real IPIN 2023 site, regenerated from ../shared/datasets.
#[test]
fn imports_the_real_ipin_site() {
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/datasets/ipin2023");
    if !data.is_dir() {
        println!("skipped: ../shared/datasets not found");
        return;
    }
    let out = tmp("real");
    let rep = import(&IpinImport {
        dataset_dir: data,
        out: out.join("site"),
        pixels_per_meter: 10.0,
        open_margin_m: DEFAULT_OPEN_MARGIN_M,
    })
    .unwrap();
    assert_eq!(rep.logs, 42);
    assert_eq!(rep.beacons.len(), 6);
    let ids: Vec<i32> = rep.floors.iter().map(|f| f.id).collect();
    assert_eq!(ids, vec![0, -1, -2]);
    for f in &rep.floors {
        // Every truth point lies in walkable space.
        assert!(
            f.truth_points > 0 && f.truth_walkable == f.truth_points,
            "{f:?}"
        );
    }
    // Barometric heights: below ground and ordered (mezzanine above basement).
    let h: Vec<f64> = rep.floors.iter().map(|f| f.height_m).collect();
    assert!(
        h[0] == 0.0 && h[1] < -1.5 && h[2] < h[1] - 1.0 && h[2] > -12.0,
        "{h:?}"
    );
    // Beacons lie inside the image frame, near the truth of their floor.
    for b in &rep.beacons {
        let fl = rep.floors.iter().find(|f| f.id == b.floor).unwrap();
        let bb = fl.truth_bbox_m;
        assert!(b.x_m > bb[0] - 10.0 && b.x_m < bb[2] + 10.0, "{b:?}");
        assert!(b.y_m > bb[1] - 10.0 && b.y_m < bb[3] + 10.0, "{b:?}");
    }
    // The site loads and validates with the project's loader (Site::build).
    let site = fpbp_core::site::files::load_site(&out.join("site/site.json")).unwrap();
    assert_eq!(site.floors.len(), 3);
    assert!(
        site.floors.iter().all(|m| m.rooms().len() == 1),
        "open floors and the stair block"
    );
    // The log reader (fpbp_logs) with the site's georeference: every beacon
    // heard is a site beacon, and the truth lands on walkable pixels of its floor.
    let spec: SiteSpec =
        serde_json::from_str(&std::fs::read_to_string(out.join("site/site.json")).unwrap())
            .unwrap();
    let opts = fpbp_logs::ReadOptions {
        site_georef: spec.georef.map(|g| (g, spec.map_from_enu_rad)),
        ..Default::default()
    };
    let log = Path::new(env!("CARGO_MANIFEST_DIR")).join(
        "../../../shared/datasets/ipin2023/logs/IPIN2023_T3_TrainingTrial51_repetition02.txt.gz",
    );
    let (events, _) = fpbp_logs::read_all(&log, &opts).unwrap();
    let site_ids: Vec<&str> = spec.beacons.iter().map(|b| b.id.as_str()).collect();
    let grid = Grid::covering(rep.width_m, rep.height_m, 10.0);
    let (mut heard, mut truth) = (std::collections::BTreeSet::new(), 0);
    for e in &events {
        match e {
            fpbp_core::events::LogEvent::Ble(b) => {
                assert!(site_ids.contains(&b.beacon_id.as_str()), "{}", b.beacon_id);
                heard.insert(b.beacon_id.clone());
            }
            fpbp_core::events::LogEvent::Truth(t) => {
                truth += 1;
                let f = t.floor.unwrap();
                let img = image::open(out.join(format!("site/plan_{f}.png")))
                    .unwrap()
                    .to_rgb8();
                let map = floor_map(
                    &grid,
                    img.pixels()
                        .map(|p| {
                            if p.0 == [255, 255, 255] {
                                Feature::Walkable
                            } else {
                                Feature::Wall
                            }
                        })
                        .collect(),
                );
                assert!(map.is_walkable(Vec2::new(t.x_m, t.y_m)), "{t:?}");
            }
            _ => {}
        }
    }
    assert_eq!(truth, 16);
    assert!(heard.len() >= 3, "{heard:?}");
    std::fs::remove_dir_all(&out).ok();
}
