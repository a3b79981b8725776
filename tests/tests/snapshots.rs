//! Snapshots of `qloop check` reports and generated code for every seed spec.
//! Review every changed `.snap` as a code diff; never accept blindly. A text over
//! [`qloop_tests::snapshot::FULL_LIMIT`] bytes is snapshotted as its outline and digest.

use qloop_tests::all_specs;
use qloop_tests::snapshot::snapshot_text;

#[test]
fn check_reports_and_generated_code() {
    let specs = all_specs();
    assert!(specs.len() >= 2, "seed specs missing");
    for (stem, src) in specs {
        let plan = qloop::compile_str(&src, &qloop::Target::default()).unwrap();
        let file = format!("{stem}.qloop");
        insta::assert_snapshot!(
            format!("{stem}_check"),
            qloop::report::check_report(&plan, &file)
        );
        insta::assert_snapshot!(
            format!("{stem}_rust"),
            snapshot_text(&qloop::gen_rust(&plan))
        );
        insta::assert_snapshot!(
            format!("{stem}_reference"),
            snapshot_text(&qloop::gen_reference(&plan))
        );
    }
}
