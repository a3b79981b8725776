//! The search space of `qloop tune`: every combination of the spec's `tune` candidates, and
//! each candidate spec as source text (the tuned constants' value expressions rewritten).

use qloop::ir::Tune;

/// Most combinations a tuning run tries.
pub const MAX_COMBINATIONS: usize = 4096;

/// One point of the space: a value per `tune` item, in the items' order.
pub type Point = Vec<f64>;

/// Every combination of the candidates (the last item varies fastest).
pub fn points(tunes: &[Tune]) -> Vec<Point> {
    let mut out: Vec<Point> = vec![Vec::new()];
    for t in tunes {
        out = out
            .into_iter()
            .flat_map(|p| {
                t.values.iter().map(move |v| {
                    let mut q = p.clone();
                    q.push(*v);
                    q
                })
            })
            .collect();
    }
    out
}

/// How many combinations the items give (saturating).
pub fn count(tunes: &[Tune]) -> usize {
    tunes
        .iter()
        .fold(1usize, |n, t| n.saturating_mul(t.values.len()))
}

/// A value as the literal written into the spec: the shortest decimal that reads back as
/// the same f64, after snapping grid points (`LO + k·H`) to 12 significant digits, so that
/// `0.30000000000000004` is written `0.3`. Always with a decimal point.
pub fn literal(v: f64) -> String {
    let snapped: f64 = format!("{v:.12e}").parse().unwrap_or(v);
    let s = format!("{snapped:?}");
    if s.contains('.') || s.contains('e') {
        s
    } else {
        format!("{s}.0")
    }
}

/// The candidate value actually used for `v` (what [`literal`] writes).
pub fn written(v: f64) -> f64 {
    literal(v).parse().unwrap_or(v)
}

/// The byte range in `src` of each tuned constant's value expression.
pub fn value_ranges(src: &str, tunes: &[Tune]) -> Vec<(usize, usize)> {
    tunes
        .iter()
        .map(|t| qloop::Diag::new(t.value_span, "").byte_range(src))
        .collect()
}

/// `src` with each tuned constant's value expression (its byte range in `ranges`, from
/// [`value_ranges`]) replaced by the point's value, and, with `rename`, the controller's name
/// (its byte range given) replaced.
pub fn substitute(
    src: &str,
    ranges: &[(usize, usize)],
    point: &[f64],
    rename: Option<((usize, usize), &str)>,
) -> String {
    let mut edits: Vec<((usize, usize), String)> = ranges
        .iter()
        .zip(point)
        .map(|(r, v)| (*r, literal(*v)))
        .collect();
    if let Some((r, name)) = rename {
        edits.push((r, name.to_string()));
    }
    // From the end, so that earlier offsets stay valid.
    edits.sort_by_key(|e| std::cmp::Reverse(e.0 .0));
    let mut out = src.to_string();
    for ((a, b), text) in edits {
        out.replace_range(a..b, &text);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn literals_read_back_and_snap_grid_points() {
        assert_eq!(literal(0.1 + 0.2), "0.3");
        assert_eq!(literal(1.0), "1.0");
        assert_eq!(literal(0.015625), "0.015625");
        assert_eq!(literal(0.3 + 3.0 * 0.1), "0.6");
        for v in [0.25, 1.25, 0.7, 1e-7, 123456.5] {
            assert_eq!(written(v), v, "{v}");
        }
    }
}
