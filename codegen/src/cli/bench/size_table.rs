//! The size table and its JSON: per variant the controller's flash and RAM, the whole ELF's,
//! and whether the firmware fits the target's memory (see [`super::size`] for what is
//! counted).

use super::report::{Run, ORDER};
use super::size::Footprint;
use std::fmt::Write as _;

/// `yes`, or `no: REASONS`, or `?` without limits.
fn verdict(f: &Footprint) -> String {
    match f.misfits() {
        None => "? (no memory regions in the link map)".to_string(),
        Some(why) if why.is_empty() => "yes".to_string(),
        Some(why) => format!("no: {}", why.join("; ")),
    }
}

/// The limits the fit is checked against, for the header.
fn limits(r: &Run) -> String {
    let Some(f) = r.sizes.first() else {
        return String::new();
    };
    let (fr, rr) = r.pf.regions();
    match (f.flash_limit, f.ram_limit) {
        (Some(fl), Some(rl)) => format!(
            "flash {fl} (region `{fr}`), RAM {rl} (region `{rr}`){}",
            if fr == rr { ", one region" } else { "" }
        ),
        _ => "memory unknown".to_string(),
    }
}

/// Prints the size table: one row per built variant.
pub(super) fn table(r: &Run, o: &mut String) {
    let _ = writeln!(
        o,
        "\nsizes in bytes. controller flash = what its own objects (step fn, init, helpers, \
         tables) and the library routines they need (`lib`) put in the firmware; controller RAM \
         = its state object + their static data; step frame = the step's own stack frame \
         (-fstack-usage, library calls not included); whole ELF = the benchmark firmware: \
         harness, {}-step input table, startup and reporting included (flash = text + data, \
         RAM = data + bss).",
        r.a.steps
    );
    let _ = writeln!(
        o,
        "{:<10} {:>10} {:>9} {:>8} {:>9} {:>8} {:>10} {:>10} {:>9}  fits ({})",
        "variant",
        "ctrl flash",
        "step fn",
        "lib",
        "ctrl RAM",
        "state",
        "step frame",
        "ELF flash",
        "ELF RAM",
        limits(r)
    );
    for name in ORDER {
        let Some(i) = r.find(name) else { continue };
        let f = &r.sizes[i];
        let opt = |x: Option<u64>| x.map_or("?".to_string(), |n| n.to_string());
        let _ = writeln!(
            o,
            "{:<10} {:>10} {:>9} {:>8} {:>9} {:>8} {:>10} {:>10} {:>9}  {}",
            name,
            f.ctrl_flash(),
            opt(f.step),
            f.lib.flash(),
            f.ctrl_ram(),
            f.state,
            opt(f.frame.as_ref().map(|x| x.0)),
            f.elf.flash(),
            f.elf.ram(),
            verdict(f)
        );
    }
}

/// The JSON fields of the sizes: per variant the summary numbers (`controller_flash`, ...,
/// like `step`) and the details (`sizes`).
pub(super) fn json(r: &Run) -> serde_json::Map<String, serde_json::Value> {
    use serde_json::{json, Map, Value};
    let per = |f: &dyn Fn(&Footprint) -> Value| {
        let mut m = Map::new();
        for name in ORDER {
            let v = r.find(name).map_or(Value::Null, |i| f(&r.sizes[i]));
            m.insert(name.to_string(), v);
        }
        Value::Object(m)
    };
    let b = |x: super::size::Berkeley| json!({"text": x.text, "data": x.data, "bss": x.bss});
    let mut out = Map::new();
    out.insert("controller_flash".into(), per(&|f| json!(f.ctrl_flash())));
    out.insert("controller_ram".into(), per(&|f| json!(f.ctrl_ram())));
    out.insert("elf_flash".into(), per(&|f| json!(f.elf.flash())));
    out.insert("elf_ram".into(), per(&|f| json!(f.elf.ram())));
    out.insert(
        "fits".into(),
        per(&|f| f.misfits().map_or(Value::Null, |w| json!(w.is_empty()))),
    );
    out.insert(
        "sizes".into(),
        per(&|f| {
            json!({
                "controller_flash": f.ctrl_flash(),
                "controller_ram": f.ctrl_ram(),
                "controller_objects": b(f.own),
                "library": b(f.lib),
                "library_members": f.lib_members,
                "state": f.state,
                "step_function": f.step,
                "step_frame": f.frame.as_ref().map(|x| x.0),
                "step_frame_kind": f.frame.as_ref().map(|x| x.1.clone()),
                "symbols": f.symbols.iter().map(|(n, k, s)| json!({"name": n, "type": k.to_string(), "size": s})).collect::<Vec<_>>(),
                "elf": b(f.elf),
                "elf_flash": f.elf.flash(),
                "elf_ram": f.elf.ram(),
                "flash_limit": f.flash_limit,
                "ram_limit": f.ram_limit,
                "does_not_fit": f.misfits(),
                "linker": f.overflow,
            })
        }),
    );
    out.insert(
        "sizes_counted".into(),
        json!(
            "controller_flash: text+data of the variant's own objects and of the library archive \
             members they need (transitively); controller_ram: the state object (bench_state) + \
             data+bss of those; step_frame: -fstack-usage of the step function alone; elf_*: \
             the whole benchmark firmware (harness, input table, startup, reporting); flash = \
             text + data, RAM = data + bss"
        ),
    );
    out
}
