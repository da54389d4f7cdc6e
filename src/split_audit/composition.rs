//! Each role's trajectory x speed make-up and its total-variation
//! distance from the others.

use std::collections::BTreeSet;

use super::rows::{Effect, RecordingRow, RoleComposition};

/// Total-variation distance between two count vectors' shares.
fn tv_distance(a: &[usize], b: &[usize]) -> f64 {
    let (na, nb) = (a.iter().sum::<usize>() as f64, b.iter().sum::<usize>() as f64);
    if na == 0.0 || nb == 0.0 {
        return f64::NAN;
    }
    0.5 * a.iter().zip(b).map(|(&x, &y)| (x as f64 / na - y as f64 / nb).abs()).sum::<f64>()
}

pub(super) fn composition(roles: &[String], rows: &[RecordingRow]) -> RoleComposition {
    let kept = || rows.iter().filter(|r| !r.role.is_empty() && r.effect == Effect::Kept);
    let cells: Vec<(String, String)> =
        kept().map(|r| (r.trajectory.clone(), r.speed.clone())).collect::<BTreeSet<_>>().into_iter().collect();
    let counts_where = |f: &dyn Fn(&RecordingRow) -> bool| -> Vec<usize> {
        cells.iter().map(|(t, s)| kept().filter(|r| f(r) && &r.trajectory == t && &r.speed == s).count()).collect()
    };
    let counts: Vec<(String, Vec<usize>)> =
        roles.iter().map(|role| (role.clone(), counts_where(&|r| &r.role == role))).collect();
    let distance_from_rest = roles
        .iter()
        .zip(&counts)
        .map(|(role, (_, c))| (role.clone(), tv_distance(c, &counts_where(&|r| &r.role != role))))
        .collect();
    let mut pairwise = Vec::new();
    for (i, (a, ca)) in counts.iter().enumerate() {
        for (b, cb) in &counts[i + 1..] {
            pairwise.push((a.clone(), b.clone(), tv_distance(ca, cb)));
        }
    }
    RoleComposition { cells, counts, distance_from_rest, pairwise }
}
