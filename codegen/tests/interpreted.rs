//! The interpreted controllers `qloop tune` scores candidates with ([`qloop::interpreted`])
//! against the same specs compiled by `controller!` into `qloop-verified`: the plan
//! interpreter must give the compiled routine's closed-loop trace bit for bit, and the real
//! interpreter the f64 reference module's to rounding.

use qloop::interpreted::{Interpreted, RealInterpreted};
use qloop::Target;
use qloop_plant::turning::{scenarios, Turning, TurningParams};
use qloop_plant::{fixed_controller, reference_controller, run, Controller, RunConfig};
use std::rc::Rc;

fn plan(file: &str) -> Rc<qloop::Plan> {
    let path = format!("{}/../verified/specs/{file}", env!("CARGO_MANIFEST_DIR"));
    let src = std::fs::read_to_string(&path).unwrap();
    Rc::new(qloop::compile_str(&src, &Target::default()).unwrap())
}

fn check(
    file: &str,
    fixed: &dyn Fn() -> Box<dyn Controller + Send>,
    reference: &dyn Fn() -> Box<dyn Controller + Send>,
) {
    let p = plan(file);
    let plant = Turning::new(TurningParams::default());
    for sc in scenarios() {
        let compiled = run(&plant, fixed(), reference(), &sc, RunConfig::default()).unwrap();
        let interp = run(
            &plant,
            Box::new(Interpreted::new(p.clone())),
            Box::new(RealInterpreted::new(p.clone())),
            &sc,
            RunConfig::default(),
        )
        .unwrap();
        assert_eq!(compiled.columns, interp.columns);
        assert_eq!(compiled.rows.len(), interp.rows.len());
        for (k, (a, b)) in compiled.rows.iter().zip(&interp.rows).enumerate() {
            for ((c, x), y) in compiled.columns.iter().zip(a).zip(b) {
                if c.ends_with("_ref") {
                    // The reference's f64 operations may be ordered differently.
                    assert!(
                        (x - y).abs() <= 1e-9 * x.abs().max(1.0),
                        "{file} {}: row {k} {c}: {x} vs {y}",
                        sc.name
                    );
                } else {
                    assert_eq!(x, y, "{file} {}: row {k} {c}", sc.name);
                }
            }
        }
    }
}

#[test]
fn interpreted_matches_compiled() {
    check(
        "koren_masory_1981.qloop",
        &|| fixed_controller!(qloop_verified::koren_masory_1981),
        &|| reference_controller!(qloop_verified::koren_masory_1981_ref, 0.1),
    );
    check(
        "acc_fixed_gain.qloop",
        &|| fixed_controller!(qloop_verified::acc_fixed_gain),
        &|| reference_controller!(qloop_verified::acc_fixed_gain_ref, 0.1),
    );
}
