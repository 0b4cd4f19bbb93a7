//! Affinity-propagation clustering (Frey & Dueck 2007) of fingerprint RSSI
//! vectors and the relative-density outlier rule (BMW eqs. 7-8, Table 1).

use super::rssi_distance;

/// Affinity propagation on `points` with similarity -||a-b||^2 and the
/// median similarity as every point's preference. Returns each point's
/// exemplar index (a point is its own exemplar when it is one). Deterministic.
pub fn affinity_propagation(points: &[Vec<f64>], damping: f64, iterations: usize) -> Vec<usize> {
    let n = points.len();
    if n <= 1 {
        return (0..n).collect();
    }
    let mut s = vec![0.0; n * n];
    let mut off = Vec::with_capacity(n * (n - 1));
    for i in 0..n {
        for k in 0..n {
            if i != k {
                let d = rssi_distance(&points[i], &points[k]);
                s[i * n + k] = -d * d;
                off.push(-d * d);
            }
        }
    }
    off.sort_by(f64::total_cmp);
    let pref = off[off.len() / 2];
    for i in 0..n {
        // tiny index-based tie-breaker keeps degenerate (equal) inputs from oscillating
        s[i * n + i] = pref - 1e-9 * i as f64;
    }
    let mut r = vec![0.0; n * n];
    let mut a = vec![0.0; n * n];
    for _ in 0..iterations {
        for i in 0..n {
            // largest and second largest of a(i,k) + s(i,k)
            let (mut m1, mut m2, mut k1) = (f64::NEG_INFINITY, f64::NEG_INFINITY, 0);
            for k in 0..n {
                let v = a[i * n + k] + s[i * n + k];
                if v > m1 {
                    m2 = m1;
                    m1 = v;
                    k1 = k;
                } else if v > m2 {
                    m2 = v;
                }
            }
            for k in 0..n {
                let other = if k == k1 { m2 } else { m1 };
                let new = s[i * n + k] - other;
                r[i * n + k] = damping * r[i * n + k] + (1.0 - damping) * new;
            }
        }
        for k in 0..n {
            let sum_pos: f64 = (0..n)
                .filter(|&i| i != k)
                .map(|i| r[i * n + k].max(0.0))
                .sum();
            for i in 0..n {
                let new = if i == k {
                    sum_pos
                } else {
                    (r[k * n + k] + sum_pos - r[i * n + k].max(0.0)).min(0.0)
                };
                a[i * n + k] = damping * a[i * n + k] + (1.0 - damping) * new;
            }
        }
    }
    let exemplars: Vec<usize> = (0..n)
        .filter(|&k| r[k * n + k] + a[k * n + k] > 0.0)
        .collect();
    if exemplars.is_empty() {
        return vec![0; n];
    }
    (0..n)
        .map(|i| {
            if exemplars.contains(&i) {
                i
            } else {
                *exemplars
                    .iter()
                    .max_by(|&&x, &&y| s[i * n + x].total_cmp(&s[i * n + y]).then(y.cmp(&x)))
                    .unwrap_or(&exemplars[0])
            }
        })
        .collect()
}

/// Indices of the `k` nearest neighbours of `points[i]` among `members` (not i).
fn neighbours(points: &[Vec<f64>], members: &[usize], i: usize, k: usize) -> Vec<(usize, f64)> {
    let mut d: Vec<(usize, f64)> = members
        .iter()
        .filter(|&&j| j != i)
        .map(|&j| (j, rssi_distance(&points[i], &points[j])))
        .collect();
    d.sort_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)));
    d.truncate(k);
    d
}

fn density(points: &[Vec<f64>], members: &[usize], i: usize, k: usize) -> Option<f64> {
    let nb = neighbours(points, members, i, k);
    if nb.is_empty() {
        return None;
    }
    let mean = nb.iter().map(|(_, d)| d).sum::<f64>() / nb.len() as f64;
    Some(1.0 / mean.max(1e-9))
}

/// Relative density of `points[i]` among `members` (eq. 8): its density
/// (eq. 7, inverse mean distance to its k nearest neighbours) divided by the
/// mean density of those neighbours. `None` when it has no neighbour.
pub fn relative_density(points: &[Vec<f64>], members: &[usize], i: usize, k: usize) -> Option<f64> {
    let own = density(points, members, i, k)?;
    let nb = neighbours(points, members, i, k);
    let mean: f64 = nb
        .iter()
        .map(|(j, _)| density(points, members, *j, k).unwrap_or(own))
        .sum::<f64>()
        / nb.len() as f64;
    Some(own / mean.max(1e-12))
}

/// The sub-databases of Table 1.
#[derive(Debug, Clone, PartialEq)]
pub struct SubDatabases {
    /// Cluster of each point.
    pub label: Vec<usize>,
    /// Members of each cluster.
    pub members: Vec<Vec<usize>>,
    /// Cluster centre (mean RSSI vector) of each cluster.
    pub centres: Vec<Vec<f64>>,
    /// Points reassigned by the outlier rule.
    pub reassigned: usize,
}

impl SubDatabases {
    /// Table 1: AP clustering, then points whose relative density within their
    /// cluster is below `outlier_threshold` join the cluster of their nearest
    /// neighbour in another cluster, repeated until nothing moves (at most 10
    /// rounds); cluster centres are the members' mean vectors.
    pub fn build(
        points: &[Vec<f64>],
        damping: f64,
        iterations: usize,
        k: usize,
        outlier_threshold: f64,
    ) -> Self {
        let ex = affinity_propagation(points, damping, iterations);
        let mut ids: Vec<usize> = ex.clone();
        ids.sort_unstable();
        ids.dedup();
        let mut label: Vec<usize> = ex
            .iter()
            .map(|e| ids.binary_search(e).unwrap_or(0))
            .collect();
        let nclusters = ids.len().max(1);
        let mut reassigned = 0;
        for _ in 0..10 {
            let members = group(&label, nclusters);
            let mut moves = Vec::new();
            for (c, m) in members.iter().enumerate() {
                for &i in m {
                    let Some(rd) = relative_density(points, m, i, k) else {
                        continue;
                    };
                    if rd < outlier_threshold {
                        let nearest =
                            (0..points.len())
                                .filter(|&j| label[j] != c)
                                .min_by(|&x, &y| {
                                    rssi_distance(&points[i], &points[x])
                                        .total_cmp(&rssi_distance(&points[i], &points[y]))
                                        .then(x.cmp(&y))
                                });
                        if let Some(j) = nearest {
                            moves.push((i, label[j]));
                        }
                    }
                }
            }
            // one move per point; keep clusters non-empty
            let mut moved = false;
            for (i, c) in moves {
                let from = label[i];
                if label.iter().filter(|&&l| l == from).count() > 1 {
                    label[i] = c;
                    reassigned += 1;
                    moved = true;
                }
            }
            if !moved {
                break;
            }
        }
        let members = group(&label, nclusters);
        let centres = centres(points, &members);
        SubDatabases {
            label,
            members,
            centres,
            reassigned,
        }
    }

    /// Sub-databases from stored labels (cluster of each point, as in a saved
    /// database): members and centres recomputed, no clustering. `None` when
    /// the lengths differ or a label is >= `clusters`.
    pub fn from_labels(
        points: &[Vec<f64>],
        label: Vec<usize>,
        clusters: usize,
        reassigned: usize,
    ) -> Option<Self> {
        if label.len() != points.len() || label.iter().any(|&l| l >= clusters) {
            return None;
        }
        let members = group(&label, clusters);
        let centres = centres(points, &members);
        Some(SubDatabases {
            label,
            members,
            centres,
            reassigned,
        })
    }

    /// The `n` clusters whose centres are nearest to `scan` (NaN = not heard,
    /// see [`super::scan_distance`]), nearest first (empty clusters skipped).
    pub fn best(&self, scan: &[f64], n: usize) -> Vec<usize> {
        let mut c: Vec<(usize, f64)> = self
            .centres
            .iter()
            .enumerate()
            .filter(|(i, _)| !self.members[*i].is_empty())
            .map(|(i, c)| (i, super::scan_distance(scan, c)))
            .collect();
        c.sort_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)));
        c.into_iter().take(n).map(|(i, _)| i).collect()
    }
}

/// Mean vector of each cluster's members.
fn centres(points: &[Vec<f64>], members: &[Vec<usize>]) -> Vec<Vec<f64>> {
    let dim = points.first().map_or(0, |p| p.len());
    members
        .iter()
        .map(|m| {
            let mut c = vec![0.0; dim];
            for &i in m {
                for (cj, pj) in c.iter_mut().zip(&points[i]) {
                    *cj += pj;
                }
            }
            let n = m.len().max(1) as f64;
            c.iter_mut().for_each(|v| *v /= n);
            c
        })
        .collect()
}

fn group(label: &[usize], n: usize) -> Vec<Vec<usize>> {
    let mut g = vec![Vec::new(); n];
    for (i, &l) in label.iter().enumerate() {
        if let Some(v) = g.get_mut(l) {
            v.push(i);
        }
    }
    g
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Three tight blobs in 2-D RSSI space.
    fn blobs() -> Vec<Vec<f64>> {
        let mut p = Vec::new();
        for (cx, cy) in [(-60.0, -90.0), (-90.0, -60.0), (-75.0, -75.0)] {
            for i in 0..6 {
                let a = i as f64;
                p.push(vec![cx + (a * 1.3).sin(), cy + (a * 2.1).cos()]);
            }
        }
        p
    }

    #[test]
    fn ap_finds_three_blobs() {
        let p = blobs();
        let ex = affinity_propagation(&p, 0.7, 300);
        let mut ids = ex.clone();
        ids.sort_unstable();
        ids.dedup();
        assert_eq!(ids.len(), 3, "{ex:?}");
        for b in 0..3 {
            let e = ex[b * 6];
            assert!(ex[b * 6..b * 6 + 6].iter().all(|&x| x == e), "{ex:?}");
            assert!((b * 6..b * 6 + 6).contains(&e));
        }
        assert_eq!(affinity_propagation(&p, 0.7, 300), ex, "deterministic");
        assert!(affinity_propagation(&[], 0.7, 10).is_empty());
        assert_eq!(affinity_propagation(&[vec![1.0]], 0.7, 10), vec![0]);
    }

    #[test]
    fn relative_density_flags_the_isolated_point() {
        let mut p: Vec<Vec<f64>> = (0..8).map(|i| vec![i as f64 * 0.5, 0.0]).collect();
        p.push(vec![30.0, 0.0]);
        let all: Vec<usize> = (0..p.len()).collect();
        let rd_far = relative_density(&p, &all, 8, 3).unwrap();
        let rd_mid = relative_density(&p, &all, 4, 3).unwrap();
        assert!(rd_far < 0.2, "{rd_far}");
        assert!((rd_mid - 1.0).abs() < 0.3, "{rd_mid}");
        assert_eq!(relative_density(&p, &[4], 4, 3), None);
    }

    #[test]
    fn outlier_rule_moves_a_stray_point_to_its_nearest_neighbours_cluster() {
        // two clusters; point 10 sits next to cluster B but is forced into A
        let mut p: Vec<Vec<f64>> = (0..5).map(|i| vec![i as f64 * 0.3, 0.0]).collect();
        p.extend((0..5).map(|i| vec![20.0 + i as f64 * 0.3, 0.0]));
        p.push(vec![21.7, 0.0]);
        let sub = SubDatabases::build(&p, 0.7, 300, 3, 0.5);
        assert_eq!(sub.label[10], sub.label[5], "{:?}", sub.label);
        assert_ne!(sub.label[0], sub.label[5]);
        let best = sub.best(&[0.5, 0.0], 1);
        assert_eq!(best, vec![sub.label[0]]);
        // the rule itself: with a forced wrong label, relative density is low
        let members_a: Vec<usize> = (0..5).chain([10]).collect();
        let rd = relative_density(&p, &members_a, 10, 3).unwrap();
        assert!(rd < 0.5, "{rd}");
    }
}
