//! The β-FROH discretisation (Rubio & De la Sen, eqs. 4–5) against scipy: the stored
//! oracle `tests/oracle/froh_scipy.toml` is written (and, in CI, re-checked) by
//! `tests/oracle/froh_scipy.py`, which builds every β-FROH model from scipy's own ZOH and
//! triangle-hold discretisations and from Rubio & De la Sen, eq. 5, sharing no code with `froh.rs`.

use qloop_plant::froh::{froh, zoh, ContinuousTf, PAPER_BETAS};
use serde::Deserialize;

#[derive(Deserialize)]
struct Oracle {
    period: f64,
    plant: Model,
    reference: Model,
}

#[derive(Deserialize)]
struct Model {
    num: Vec<f64>,
    den: Vec<f64>,
    zoh_num: Vec<f64>,
    zoh_den: Vec<f64>,
    froh: Vec<Row>,
}

#[derive(Deserialize)]
struct Row {
    beta: f64,
    impulse: Vec<f64>,
}

fn oracle() -> Oracle {
    let text = include_str!("oracle/froh_scipy.toml");
    toml::from_str(text).expect("the oracle file parses")
}

fn close(a: f64, b: f64, scale: f64) -> bool {
    (a - b).abs() <= 1e-10 * scale
}

#[test]
fn froh_matches_scipy() {
    let o = oracle();
    for (name, m, paper) in [
        ("plant", &o.plant, ContinuousTf::paper_initial_model()),
        (
            "reference",
            &o.reference,
            ContinuousTf::paper_reference_model(),
        ),
    ] {
        assert_eq!((&m.num, &m.den), (&paper.num, &paper.den), "{name}");
        let g = ContinuousTf::new(&m.num, &m.den);
        // β = 0 is scipy's ZOH, coefficient by coefficient.
        let z = zoh(&g, o.period).expect("zoh");
        assert_eq!(z.num.len(), m.zoh_num.len(), "{name}");
        for (x, y) in z
            .num
            .iter()
            .zip(&m.zoh_num)
            .chain(z.den.iter().zip(&m.zoh_den))
        {
            assert!(
                close(*x, *y, 1.0),
                "{name} ZOH: {z:?} vs {:?}/{:?}",
                m.zoh_num,
                m.zoh_den
            );
        }
        // Every β of the paper's set: the impulse response, which determines the model.
        let betas: Vec<f64> = m.froh.iter().map(|r| r.beta).collect();
        assert_eq!(betas, PAPER_BETAS, "{name}");
        for row in &m.froh {
            let h = froh(&g, o.period, row.beta).expect("froh");
            let ours = h.impulse(row.impulse.len());
            let scale = row.impulse.iter().fold(0.0f64, |a, x| a.max(x.abs()));
            for (k, (x, y)) in ours.iter().zip(&row.impulse).enumerate() {
                assert!(
                    close(*x, *y, scale),
                    "{name}, β = {}: h[{k}] = {x} but scipy gives {y}",
                    row.beta
                );
            }
        }
    }
}

#[test]
fn froh_at_one_is_not_scipys_triangle_hold() {
    // β = 1 is Rubio & De la Sen's causal FOH: its first sample after the impulse is larger than the
    // ZOH's (the hold extrapolates upward for one period), and it is causal (h[0] = 0 for a
    // strictly proper plant), unlike scipy's "foh", the non-causal triangle hold.
    let g = ContinuousTf::paper_initial_model();
    let h1 = froh(&g, 0.0839, 1.0).expect("froh").impulse(3);
    let h0 = zoh(&g, 0.0839).expect("zoh").impulse(3);
    assert_eq!(h1[0], 0.0);
    assert!(h1[1] > h0[1], "{h1:?} vs {h0:?}");
}
