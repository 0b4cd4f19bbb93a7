//! Checks of a caller's position (`Engine::set_position`, a tap on the map or
//! a QR code) shared by the engines that accept one.

use crate::engine::InitialPosition;
use crate::site::Site;
use crate::{Error, Result};

/// `at` must be finite and on one of the site's floors; its heading, when
/// given, finite. Errors name the engine and the value at fault.
pub fn check(engine: &str, site: &Site, at: &InitialPosition) -> Result<()> {
    if !(at.x_m.is_finite() && at.y_m.is_finite()) {
        return Err(Error::Input(format!(
            "engine `{engine}`: position ({}, {}) is not finite",
            at.x_m, at.y_m
        )));
    }
    if let Some(h) = at.heading_rad
        && !h.is_finite()
    {
        return Err(Error::Input(format!(
            "engine `{engine}`: heading {h} rad is not finite"
        )));
    }
    if !site.spec.floors.iter().any(|f| f.id == at.floor) {
        let ids: Vec<String> = site.spec.floors.iter().map(|f| f.id.to_string()).collect();
        return Err(Error::Input(format!(
            "engine `{engine}`: floor {} is not on site `{}` (floors: {})",
            at.floor,
            site.spec.name,
            ids.join(", ")
        )));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::site::testkit::{beacon_site, open_map};

    fn at(x_m: f64, floor: i32, heading_rad: Option<f64>) -> InitialPosition {
        InitialPosition {
            x_m,
            y_m: 1.0,
            floor,
            heading_rad,
        }
    }

    #[test]
    fn names_what_is_wrong() {
        let model = crate::ble::pathloss::PathLoss {
            rssi_1m_dbm: -59.0,
            exponent: 2.0,
        };
        let site = beacon_site("t", vec![open_map(10, 10)], &[], model);
        assert!(check("e", &site, &at(1.0, 0, Some(0.5))).is_ok());
        assert!(check("e", &site, &at(1.0, 0, None)).is_ok());
        let e = check("e", &site, &at(f64::NAN, 0, None)).unwrap_err();
        assert!(e.to_string().contains("not finite"), "{e}");
        let e = check("e", &site, &at(1.0, 0, Some(f64::INFINITY))).unwrap_err();
        assert!(e.to_string().contains("heading"), "{e}");
        let e = check("e", &site, &at(1.0, 3, None)).unwrap_err();
        assert!(
            e.to_string().contains("floor 3") && e.to_string().contains("floors: 0"),
            "{e}"
        );
    }
}
