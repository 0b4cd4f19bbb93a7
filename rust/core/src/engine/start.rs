//! The one rule every start position and `set_position` is checked by.

use super::InitialPosition;
use crate::{Error, Result, site::Site};

/// Checks a start position against `site`: finite coordinates on a floor the
/// site has, inside that floor's plan, and a finite heading when one is
/// given. Every engine's start and `set_position` go through it.
pub fn check_initial_position(site: &Site, at: &InitialPosition) -> Result<()> {
    let bad =
        |field: &str, msg: String| Err(Error::config(format!("initial_position.{field}"), msg));
    if !(at.x_m.is_finite() && at.y_m.is_finite()) {
        return bad(
            "x_m",
            format!("must be finite, got ({}, {})", at.x_m, at.y_m),
        );
    }
    let Some(map) = site.floor(at.floor) else {
        let ids: Vec<String> = site.spec.floors.iter().map(|f| f.id.to_string()).collect();
        return bad(
            "floor",
            format!(
                "no floor {} on the site (floors: {})",
                at.floor,
                ids.join(", ")
            ),
        );
    };
    let (w, h) = (map.width_m(), map.height_m());
    if !(0.0..=w).contains(&at.x_m) || !(0.0..=h).contains(&at.y_m) {
        return bad(
            "x_m",
            format!(
                "({}, {}) m lies outside floor {}'s plan [0, {w:.2}] x [0, {h:.2}] m",
                at.x_m, at.y_m, at.floor
            ),
        );
    }
    if let Some(hd) = at.heading_rad
        && !hd.is_finite()
    {
        return bad("heading_rad", format!("must be finite, got {hd}"));
    }
    Ok(())
}
