//! `qloop gen --lang linuxcnc`: where it writes the component, which target it plans for, and
//! how it refuses what it cannot write.

use crate::common::{qloop, spec, text};
use std::path::PathBuf;

fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("qloop-gen-linuxcnc-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

const KOREN: &str = "koren_masory_1981.qloop";
const COMP: &str = "qloop_koren_masory_1981.comp";

#[test]
fn out_dir_and_output_file_get_what_stdout_gets() {
    let o = qloop(&["gen", &spec(KOREN), "--lang", "linuxcnc"]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    let stdout = text(&o.stdout);
    assert!(stdout.starts_with("component qloop_koren_masory_1981 "));
    // Planned for `host` unless told otherwise.
    assert!(
        stdout.contains("`qloop gen --lang c --target host`"),
        "{stdout}"
    );

    let dir = scratch("out").join("new/sub");
    let o = qloop(&[
        "gen",
        &spec(KOREN),
        "--lang",
        "linuxcnc",
        "--out",
        dir.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    assert_eq!(std::fs::read_to_string(dir.join(COMP)).unwrap(), stdout);
    let files: Vec<_> = std::fs::read_dir(&dir).unwrap().flatten().collect();
    assert_eq!(files.len(), 1, "only the component, no temporary file");

    let file = dir.join("again").join(COMP);
    std::fs::create_dir_all(file.parent().unwrap()).unwrap();
    let o = qloop(&[
        "gen",
        &spec(KOREN),
        "--lang",
        "linuxcnc",
        "-o",
        file.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    assert_eq!(std::fs::read_to_string(&file).unwrap(), stdout);
    std::fs::remove_dir_all(scratch("out")).ok();
}

#[test]
fn target_can_be_chosen() {
    let o = qloop(&[
        "gen",
        &spec(KOREN),
        "--lang",
        "linuxcnc",
        "--target",
        "cortex-m4",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    assert!(text(&o.stdout).contains("`qloop gen --lang c --target cortex-m4`"));
    // Other languages keep their default target.
    let o = qloop(&["gen", &spec(KOREN), "--lang", "c"]);
    assert!(
        text(&o.stdout).contains("target `rv32i`"),
        "{}",
        text(&o.stdout)
    );
}

#[test]
fn a_file_not_named_after_the_component_is_refused() {
    let dir = scratch("name");
    std::fs::create_dir_all(&dir).unwrap();
    for bad in [
        "acc.comp",
        "koren_masory_1981.comp",
        "qloop_koren_masory_1981.c",
    ] {
        let p = dir.join(bad);
        let o = qloop(&[
            "gen",
            &spec(KOREN),
            "--lang",
            "linuxcnc",
            "-o",
            p.to_str().unwrap(),
        ]);
        assert_eq!(o.status.code(), Some(2), "{bad}");
        let err = text(&o.stderr);
        assert!(err.contains(COMP) && err.contains("halcompile"), "{err}");
        assert!(!p.exists(), "{bad} written");
    }
    let o = qloop(&[
        "gen",
        &spec(KOREN),
        "--lang",
        "linuxcnc",
        "-o",
        dir.join(COMP).to_str().unwrap(),
        "--out",
        dir.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(text(&o.stderr).contains("not both"), "{}", text(&o.stderr));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn an_unrepresentable_spec_exits_2_with_the_reason() {
    let dir = scratch("bad");
    std::fs::create_dir_all(&dir).unwrap();
    let f = dir.join("t.qloop");
    std::fs::write(
        &f,
        "controller t {\n period 0.01 \"s\";\n input x: [0.0, 1.0];\n input steps: [0.0, 1.0];\n \
         output y;\n step { y = x + steps; }\n}\n",
    )
    .unwrap();
    let o = qloop(&[
        "gen",
        f.to_str().unwrap(),
        "--lang",
        "linuxcnc",
        "--out",
        dir.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    let err = text(&o.stderr);
    assert!(
        err.contains("cannot become a LinuxCNC HAL component"),
        "{err}"
    );
    assert!(err.contains("`steps`"), "{err}");
    assert!(!dir.join("qloop_t.comp").exists());
    std::fs::remove_dir_all(&dir).ok();
}
