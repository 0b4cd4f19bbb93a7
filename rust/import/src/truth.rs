//! Minimal truth extractors used by the importers' checks: ILC `TYPE_WAYPOINT`
//! rows (floor metres) and IPIN `POSI` rows (WGS-84 + floor). They read only
//! the truth lines (plain or gzipped files); the full log readers live in
//! rust/logs.

use anyhow::{Context, Result};
use std::io::{BufRead, BufReader, Read};
use std::path::Path;

/// Opens a plain or `.gz` text file.
pub fn open_text(path: &Path) -> Result<Box<dyn BufRead>> {
    let f = std::fs::File::open(path).with_context(|| format!("opening {}", path.display()))?;
    let r: Box<dyn Read> = if path.extension().is_some_and(|e| e == "gz") {
        Box::new(flate2::read::GzDecoder::new(f))
    } else {
        Box::new(f)
    };
    Ok(Box::new(BufReader::new(r)))
}

/// One ILC waypoint: epoch milliseconds and floor metres.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Waypoint {
    pub t_ms: i64,
    pub x_m: f64,
    pub y_m: f64,
}

/// The waypoints of an ILC trace, sorted by time, duplicates removed
/// (the ILC app writes the last waypoint twice).
pub fn ilc_waypoints(path: &Path) -> Result<Vec<Waypoint>> {
    let mut out = Vec::new();
    for (n, line) in open_text(path)?.lines().enumerate() {
        let line = line.with_context(|| format!("{}: line {}", path.display(), n + 1))?;
        let mut it = line.split('\t');
        let (Some(t), Some("TYPE_WAYPOINT"), Some(x), Some(y)) =
            (it.next(), it.next(), it.next(), it.next())
        else {
            continue;
        };
        let parsed = (
            t.trim().parse::<i64>(),
            x.trim().parse::<f64>(),
            y.trim().parse::<f64>(),
        );
        match parsed {
            (Ok(t_ms), Ok(x_m), Ok(y_m)) if x_m.is_finite() && y_m.is_finite() => {
                out.push(Waypoint { t_ms, x_m, y_m })
            }
            _ => anyhow::bail!("{}: line {}: bad TYPE_WAYPOINT row", path.display(), n + 1),
        }
    }
    out.sort_by_key(|w| w.t_ms);
    out.dedup_by(|a, b| a.t_ms == b.t_ms && a.x_m == b.x_m && a.y_m == b.y_m);
    Ok(out)
}

/// One IPIN POSI point: app seconds, WGS-84 degrees and floor id.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Posi {
    pub t_s: f64,
    pub lat_deg: f64,
    pub lon_deg: f64,
    pub floor: i32,
}

/// The truth and barometer rows of one IPIN logfile.
pub type PosiAndPressure = (Vec<Posi>, Vec<(f64, f64)>);

/// The POSI rows and the PRES (t_s, hPa) rows of an IPIN logfile.
pub fn ipin_posi_and_pressure(path: &Path) -> Result<PosiAndPressure> {
    let mut posi = Vec::new();
    let mut pres = Vec::new();
    for (n, line) in open_text(path)?.lines().enumerate() {
        let line = line.with_context(|| format!("{}: line {}", path.display(), n + 1))?;
        let bad = || {
            format!(
                "{}: line {}: bad {} row",
                path.display(),
                n + 1,
                &line[..4.min(line.len())]
            )
        };
        if let Some(rest) = line.strip_prefix("POSI;") {
            let f: Vec<&str> = rest.split(';').collect();
            if f.len() < 5 {
                anyhow::bail!(bad());
            }
            let t_s: f64 = f[0].trim().parse().with_context(bad)?;
            let lat_deg: f64 = f[2].trim().parse().with_context(bad)?;
            let lon_deg: f64 = f[3].trim().parse().with_context(bad)?;
            let floor_f: f64 = f[4].trim().parse().with_context(bad)?;
            if !(lat_deg.abs() <= 90.0 && lon_deg.abs() <= 180.0 && floor_f.fract() == 0.0) {
                anyhow::bail!(bad());
            }
            posi.push(Posi {
                t_s,
                lat_deg,
                lon_deg,
                floor: floor_f as i32,
            });
        } else if let Some(rest) = line.strip_prefix("PRES;") {
            let f: Vec<&str> = rest.split(';').collect();
            if f.len() < 3 {
                anyhow::bail!(bad());
            }
            let t_s: f64 = f[0].trim().parse().with_context(bad)?;
            let p: f64 = f[2].trim().parse().with_context(bad)?;
            if p.is_finite() && p > 0.0 {
                pres.push((t_s, p));
            }
        }
    }
    Ok((posi, pres))
}

/// Files in `dir` whose name ends with one of `suffixes`, sorted by name.
pub fn list_files(dir: &Path, suffixes: &[&str]) -> Result<Vec<std::path::PathBuf>> {
    let mut out = Vec::new();
    for e in std::fs::read_dir(dir).with_context(|| format!("listing {}", dir.display()))? {
        let p = e?.path();
        let name = p.file_name().and_then(|n| n.to_str()).unwrap_or("");
        if p.is_file() && suffixes.iter().any(|s| name.ends_with(s)) {
            out.push(p);
        }
    }
    out.sort();
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_waypoints_and_posi() {
        let dir = std::env::temp_dir().join(format!("fpbp-import-truth-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let ilc = dir.join("a.txt");
        std::fs::write(
            &ilc,
            "#\tstartTime:1\n5\tTYPE_WAYPOINT\t3.5\t4.0\n2\tTYPE_ACCELEROMETER\t1\t2\t3\t3\n1\tTYPE_WAYPOINT\t1.0\t2.0\n5\tTYPE_WAYPOINT\t3.5\t4.0\n",
        )
        .unwrap();
        let w = ilc_waypoints(&ilc).unwrap();
        assert_eq!(w.len(), 2);
        assert_eq!((w[0].t_ms, w[1].x_m), (1, 3.5));
        let ipin = dir.join("b.txt");
        std::fs::write(
            &ipin,
            "% header\nPRES;1.0;2.0;990.5;3\nPOSI;61.2;1;49.46;11.11;-2;100\nPRES;1.5;2.5;990.6;3\n",
        )
        .unwrap();
        let (p, pr) = ipin_posi_and_pressure(&ipin).unwrap();
        assert_eq!(p.len(), 1);
        assert_eq!(p[0].floor, -2);
        assert_eq!(pr, vec![(1.0, 990.5), (1.5, 990.6)]);
        std::fs::write(&ipin, "POSI;61.2;1;north;11.11;-2;100\n").unwrap();
        let e = format!("{:#}", ipin_posi_and_pressure(&ipin).unwrap_err());
        assert!(e.contains("line 1") && e.contains("POSI"), "{e}");
        std::fs::remove_dir_all(&dir).ok();
    }
}
