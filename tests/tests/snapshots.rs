//! Snapshots of `qloop check` reports and generated code for every seed spec.
//! Review every changed `.snap` as a code diff; never accept blindly.

use qloop_tests::all_specs;

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
        insta::assert_snapshot!(format!("{stem}_rust"), qloop::gen_rust(&plan));
        insta::assert_snapshot!(format!("{stem}_reference"), qloop::gen_reference(&plan));
    }
}
