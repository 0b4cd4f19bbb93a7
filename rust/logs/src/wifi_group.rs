//! Groups WiFi rows (one access point per row, as ILC `TYPE_WIFI` and IPIN
//! `WIFI` write them) into scans: consecutive rows of one arrival time are
//! one [`WifiScan`]. On the shared datasets the rows of one arrival time are
//! always consecutive (checked over all 2105 ILC and 2892 IPIN scans, tests/wifi_datasets.rs).

use fpbp_core::events::{WifiResult, WifiScan};

/// Most results one scan may hold; rows past it are malformed. The largest
/// scan of the shared data has 613 (ILC site1/F1, a mall).
pub const MAX_RESULTS_PER_SCAN: usize = 4096;

/// Collects the rows of the scan being read.
#[derive(Debug, Default)]
pub struct WifiGrouper {
    pending: Option<WifiScan>,
}

impl WifiGrouper {
    /// Adds one row. Returns the scan this row closed (the row has another
    /// time), or an error when the scan already holds
    /// [`MAX_RESULTS_PER_SCAN`] results (the row is then dropped).
    pub fn push(&mut self, t_ns: i64, result: WifiResult) -> Result<Option<WifiScan>, String> {
        if let Some(p) = &mut self.pending
            && p.t_ns == t_ns
        {
            if p.results.len() >= MAX_RESULTS_PER_SCAN {
                return Err(format!(
                    "WiFi scan at t_ns {t_ns} has more than {MAX_RESULTS_PER_SCAN} results"
                ));
            }
            p.results.push(result);
            return Ok(None);
        }
        Ok(self.pending.replace(WifiScan {
            t_ns,
            results: vec![result],
        }))
    }

    /// The scan being collected, closing it (before any other event, and at
    /// the end of the input).
    pub fn take(&mut self) -> Option<WifiScan> {
        self.pending.take()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn r(b: u8) -> WifiResult {
        WifiResult {
            bssid: format!("00:00:00:00:00:{b:02x}"),
            rssi_dbm: -50.0,
            freq_mhz: 2412,
            seen_t_ns: 0,
        }
    }

    #[test]
    fn rows_of_one_time_make_one_scan_and_the_size_is_bounded() {
        let mut g = WifiGrouper::default();
        assert_eq!(g.push(10, r(1)), Ok(None));
        assert_eq!(g.push(10, r(2)), Ok(None));
        let first = g.push(20, r(3)).unwrap().unwrap();
        assert_eq!((first.t_ns, first.results.len()), (10, 2));
        assert_eq!(g.take().unwrap().results, vec![r(3)]);
        assert_eq!(g.take(), None);
        for _ in 0..MAX_RESULTS_PER_SCAN {
            g.push(30, r(4)).unwrap();
        }
        assert!(g.push(30, r(5)).unwrap_err().contains("more than 4096"));
        assert_eq!(g.take().unwrap().results.len(), MAX_RESULTS_PER_SCAN);
    }
}
