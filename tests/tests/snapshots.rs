//! Snapshots of `qloop check` reports and generated code for every seed spec.
//! Review every changed `.snap` as a code diff; never accept blindly. A text over
//! [`qloop_tests::snapshot::FULL_LIMIT`] bytes is snapshotted as its outline and digest.

use qloop_tests::snapshot::snapshot_text;

fn check_reports_and_generated_code(stem: &str) {
    let src = qloop_tests::spec_source(stem);
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
test_tools::spec_tests! {
    check_reports_and_generated_code in "verified/specs";
    default: [
        acc_fixed_gain, gac_surface_finish, grinding_adaptive_pzc, grinding_pi, koren_masory_1981,
        koren_masory_safe, koren_masory_tuned, milling_acc,
    ];
    acceptance: [milling_multimodel];
}
