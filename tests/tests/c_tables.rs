//! The C outputs of a spec with tables (tests/tables.qloop: `r = recip(d)`, 1/x over [1, 8] in
//! 56 segments, and `f2 = f2_of(eta)`, Jenkins & Kurfess, eq. 17 over [0, 10] in 40), whose step reads two
//! constant arrays per table (`Op::Lookup`) at an index cut from the argument (`Op::Low`):
//!
//! * the fixed-point C holds each table's samples and differences as the plan has them
//!   (padded to a power of two: the samples with the last one, the differences with 0), or,
//!   where the target trades flash for cycles (the ATmega328P), the samples alone, padded
//!   past the last one, its differences read as `T[i + 1] − T[i]`; and it compiles with
//!   `-Werror` for every built-in target with that target's compiler;
//! * on the ATmega328P (avr-gcc) the arrays are in flash: `.progmem.data` in the object
//!   (none in `.data`/`.rodata`, which avr-gcc copies into the 2 KiB of RAM), `.text` in the
//!   linked firmware, read with `lpm`; the same C built without `__AVR__` puts them in
//!   `.data` (the check can tell);
//! * that firmware, run in simavr (`targets/avr/cycles.c`), computes bit for bit what qloop's
//!   plan interpreter computes, its 64-bit shifts read from their bytes (`qloop_tables_sar64`);
//! * built for the host with UBSan, every target's C equals the interpreter bit for bit, on
//!   every grid knot of each argument (±1 raw) and random raw inputs in and beyond the ranges;
//! * Frama-C Eva proves the step free of run-time errors (0 alarms), table reads included:
//!   the same C with one read moved 8 entries on gets its `index_bound` alarm;
//! * the float C (`qloop::emit::c_float`) agrees with `step_real` within a bound derived from
//!   single precision (see [`float_c_matches_the_real_interpreter`]);
//! * LinuxCNC: tables.qloop itself is refused (its output `r` is a halcompile keyword); with
//!   `r` renamed `rd`, the component builds with `halcompile --compile` and its controller
//!   and glue match the interpreter.
//!
//! Tools that are not installed skip their part (`qloop_tests::tool`).

use qloop::ir::{SigId, SigKind};
use qloop::Plan;
use qloop_tests::avr;
use qloop_tests::c_harness::{self, ids, raw_input, Case, Rng};
use qloop_tests::{run, scratch, sig, tool};
use std::collections::BTreeMap;
use std::path::Path;
use std::process::Command;

const SPEC: &str = include_str!("tables.qloop");

fn plan_of(src: &str, target: &str) -> Plan {
    let t = qloop::targets::by_name(target).unwrap_or_else(|| panic!("no target {target}"));
    qloop::compile_str(src, &t).unwrap_or_else(|e| panic!("tables.qloop for {target}: {e}"))
}

fn plan_for(target: &str) -> Plan {
    plan_of(SPEC, target)
}

/// Each input with the table it is the argument of, and the output that table gives.
const LOOKUPS: [(&str, &str, &str); 2] = [("d", "recip", "r"), ("eta", "f2_of", "f2")];

/// The table called `name` (`plan.prog.tables`).
fn table<'a>(plan: &'a Plan, name: &str) -> &'a qloop::ir::Table {
    plan.prog
        .tables
        .iter()
        .find(|t| t.name == name)
        .unwrap_or_else(|| panic!("no table {name}"))
}

/// The raw values of input `id` at every grid point of its table and one raw step either side,
/// with the declared range's ends and the storage type's.
fn knots(plan: &Plan, id: SigId, t: &qloop::ir::Table) -> Vec<i128> {
    let q = plan.format(id);
    let (lo, hi) = plan.bounds(id);
    let mut v = vec![q.ty.min(), q.ty.max(), lo - 1, lo, hi, hi + 1];
    for i in 0..=t.segments() {
        let k = q.raw_floor(t.lo + i as f64 * t.step);
        v.extend([k - 1, k, k + 1]);
    }
    v.retain(|x| (q.ty.min()..=q.ty.max()).contains(x));
    v
}

/// Every knot of each input (the other inputs random), then `random` steps of random raw
/// inputs ([`raw_input`]: mostly in range, an eighth anywhere in the storage type, an eighth
/// at the type's extremes, an eighth at the range's ends).
fn cases(plan: &Plan, rng: &mut Rng, random: usize) -> Vec<Case> {
    let inputs = ids(plan, SigKind::Input);
    let mut out = Vec::new();
    for (k, (input, t, _)) in LOOKUPS.iter().enumerate() {
        assert_eq!(inputs[k], sig(plan, input), "input order");
        for x in knots(plan, inputs[k], table(plan, t)) {
            let mut row: Vec<i128> = inputs.iter().map(|id| raw_input(plan, *id, rng)).collect();
            row[k] = x;
            out.push(Case {
                states: None,
                inputs: row,
            });
        }
    }
    for _ in 0..random {
        out.push(Case {
            states: None,
            inputs: inputs.iter().map(|id| raw_input(plan, *id, rng)).collect(),
        });
    }
    out
}

/// The numbers of a C initializer `NAME[LEN] QLOOP_PROGMEM = { ((int32_t)1), .. };` and its
/// element type.
fn c_array(c: &str, name: &str) -> (String, Vec<i128>) {
    let at = c
        .find(&format!(" {name}["))
        .unwrap_or_else(|| panic!("no array `{name}` in:\n{c}"));
    let decl = &c[c[..at].rfind('\n').unwrap() + 1..];
    let ty = decl
        .strip_prefix("static const ")
        .and_then(|d| d.split(' ').next())
        .unwrap_or_else(|| panic!("`{name}` is not a static const array"))
        .to_string();
    let open = decl.find('{').unwrap();
    let close = decl.find("};").unwrap();
    assert!(
        decl[..open].ends_with("] QLOOP_PROGMEM = "),
        "`{name}` without QLOOP_PROGMEM: {}",
        &decl[..open]
    );
    let vals = decl[open + 1..close]
        .split(", ")
        .map(|x| {
            let x = x.trim();
            let num = x
                .strip_prefix(&format!("(({ty})"))
                .and_then(|x| x.strip_suffix(')'))
                .unwrap_or_else(|| panic!("`{x}` in `{name}`"));
            num.parse()
                .unwrap_or_else(|_| panic!("`{num}` in `{name}`"))
        })
        .collect();
    (ty, vals)
}

#[test]
fn fixed_c_holds_the_plans_arrays_and_reads_them_through_the_macros() {
    let mut compacted = 0;
    for target in ["host", "atmega328p", "cortex-m0"] {
        let plan = plan_for(target);
        let (_, c) = qloop::gen_c(&plan);
        assert_eq!(plan.tables.len(), 2, "{target}: two tables");
        let layouts = qloop::emit::table_layouts(&plan);
        for (i, lt) in plan.tables.iter().enumerate() {
            let layout = layouts[i];
            let len = layout.len;
            assert!(
                len.is_power_of_two() && len >= lt.entries.len(),
                "{target}: {len}"
            );
            let mut entries = lt.entries.clone();
            entries.resize(len, *lt.entries.last().unwrap());
            let mut deltas = lt.deltas.clone();
            deltas.resize(len, 0);
            // D[i] = T[i+1] − T[i], D[N] = 0: the last segment ends on the last sample.
            for k in 0..len - 1 {
                assert_eq!(
                    entries[k] + deltas[k],
                    entries[k + 1],
                    "{target}: table {i} at {k}"
                );
            }
            let (ty, got) = c_array(&c, &format!("tables_table_{i}"));
            assert_eq!(
                ty,
                qloop::emit::c::c_ty(lt.format.ty),
                "{target}: table {i}"
            );
            assert_eq!(got, entries, "{target}: table {i}");
            let name = format!("tables_table_{i}");
            let bits = lt.format.ty.bits;
            let reads = c.matches(&format!("QLOOP_READ_{bits}({name}, ")).count();
            if layout.deltas {
                let (ty, got) = c_array(&c, &format!("tables_delta_{i}"));
                assert_eq!(
                    ty,
                    qloop::emit::c::c_ty(lt.delta_ty),
                    "{target}: deltas {i}"
                );
                assert_eq!(got, deltas, "{target}: deltas {i}");
                let dname = format!("tables_delta_{i}");
                let dbits = lt.delta_ty.bits;
                let dreads = c.matches(&format!("QLOOP_READ_{dbits}({dname}, ")).count();
                assert_eq!(dreads, 1, "{target}: reads of `{dname}`");
                assert_eq!(reads, 1, "{target}: reads of `{name}`");
                assert_eq!(
                    c.matches(&format!("{dname}[")).count(),
                    1,
                    "{target}: `{dname}[`"
                );
            } else {
                // The differences read from the samples: no array of them, one more read of
                // the samples (T[i + 1]; T[i] is the value already read), and the array
                // padded past the last sample, so that T[N + 1] − T[N] = 0.
                compacted += 1;
                assert!(
                    !c.contains(&format!("tables_delta_{i}")),
                    "{target}: deltas {i}"
                );
                assert!(len > lt.entries.len(), "{target}: table {i} not padded");
                assert_eq!(reads, 2, "{target}: reads of `{name}`");
            }
            // Read only through the macro that reads flash on AVR (`pgm_read_*`), never
            // indexed directly: `NAME[` is the declaration alone.
            assert_eq!(
                c.matches(&format!("{name}[")).count(),
                1,
                "{target}: `{name}[`"
            );
        }
        assert!(
            c.contains("#if defined(__AVR__) && !defined(__FRAMAC__)\n#include <avr/pgmspace.h>\n#define QLOOP_PROGMEM PROGMEM\n"),
            "{target}: no PROGMEM branch"
        );
    }
    // The ATmega328P's cost model trades flash for cycles (`flash_per_cycle`); the others keep
    // the differences.
    assert!(
        compacted > 0,
        "no table read its differences from its samples"
    );
}

/// The rule of `qloop::emit::table_layouts`: a table's differences are read from its samples
/// exactly where the bytes saved are at least `flash_per_cycle` times the cycles added (one
/// subtraction in the samples' type a read, every read of the step counted). Here for each
/// table of tables.qloop on the ATmega328P's cost model, at the rate of its break-even
/// point (compacted) and one above (stored), and at 0 (never).
#[test]
fn the_flash_per_cycle_rate_decides_which_tables_read_their_differences_from_their_samples() {
    let base = qloop::targets::by_name("atmega328p").expect("target");
    let with_rate = |rate: u32| {
        let mut t = base.clone();
        t.costs.flash_per_cycle = rate;
        qloop::compile_str(SPEC, &t).expect("compiles")
    };
    let plan = with_rate(0);
    assert!(qloop::emit::table_layouts(&plan)
        .iter()
        .all(|l| l.saved == 0));
    for (i, lt) in plan.tables.iter().enumerate() {
        assert_eq!(lt.delta_ty, lt.format.ty, "table {i}: one type");
        let reads = plan
            .vals
            .iter()
            .filter(|v| matches!(v.op, qloop::lower::lir::Op::Lookup { table, delta: true, .. } if table == i))
            .count() as u64;
        let n = lt.entries.len();
        let bytes = u64::from(lt.format.ty.bits / 8);
        let saved = n.next_power_of_two() as u64 * bytes
            - ((n + 1).next_power_of_two() - n.next_power_of_two()) as u64 * bytes;
        let cycles = reads * u64::from(base.add_cost(lt.format.ty.bits));
        assert!(reads > 0 && cycles > 0, "table {i}");
        let even = u32::try_from(saved / cycles).expect("small");
        let at = qloop::emit::table_layouts(&with_rate(even))[i];
        assert!(
            !at.deltas && at.saved == saved && at.len > n,
            "table {i} at rate {even}: {at:?}"
        );
        let above = qloop::emit::table_layouts(&with_rate(even + 1))[i];
        assert!(
            above.deltas && above.saved == 0,
            "table {i} at rate {}: {above:?}",
            even + 1
        );
        println!("table {i}: {saved} B for {cycles} cycles: compacted up to {even} B a cycle");
    }
}

#[test]
fn fixed_c_compiles_without_warnings_for_every_target() {
    let mut built = Vec::new();
    for t in qloop::targets::builtin() {
        let Some(cc) = t.toolchain.cc.as_deref().and_then(tool) else {
            continue;
        };
        let dir = scratch(&format!("c-tables-warn-{}", t.name));
        c_harness::warning_free(&plan_for(&t.name), &cc, &dir);
        built.push(t.name);
    }
    println!("-Werror builds: {}", built.join(", "));
}

/// `avr-objdump -t`: the section and size of each symbol.
fn symbols(objdump: &Path, file: &Path) -> BTreeMap<String, (String, u64)> {
    run(Command::new(objdump).arg("-t").arg(file))
        .lines()
        .filter_map(|l| {
            let w: Vec<&str> = l.split_whitespace().collect();
            (w.len() >= 5 && l.starts_with(|c: char| c.is_ascii_hexdigit())).then(|| {
                let n = w.len();
                let size = u64::from_str_radix(w[n - 2], 16).ok()?;
                Some((w[n - 1].to_string(), (w[n - 3].to_string(), size)))
            })?
        })
        .collect()
}

/// `avr-size -A`: the size of each section.
fn sections(size: &Path, file: &Path) -> BTreeMap<String, u64> {
    run(Command::new(size).arg("-A").arg(file))
        .lines()
        .filter_map(|l| {
            let w: Vec<&str> = l.split_whitespace().collect();
            match w.as_slice() {
                [s, n, _] if s.starts_with('.') => Some((s.to_string(), n.parse().ok()?)),
                _ => None,
            }
        })
        .collect()
}

/// On the ATmega328P the table arrays are in flash and read with `lpm`: in the object,
/// `.progmem.data` holds exactly the arrays the plan's layout stores and `.data`/`.rodata` (which the start-up
/// code copies into RAM) nothing; in the linked firmware the arrays are in `.text`. The
/// control, the same C built with `-U__AVR__` (plain `static const`), puts them in `.rodata`
/// and `.data`: the check tells the two apart.
#[test]
fn avr_tables_are_in_flash() {
    let tools: Vec<_> = ["avr-gcc", "avr-objdump", "avr-size"]
        .iter()
        .map(|t| tool(t))
        .collect();
    let [Some(cc), Some(objdump), Some(size)] = &tools[..] else {
        return;
    };
    let plan = plan_for("atmega328p");
    let mut rng = Rng(0xa7e3_2890_0000_0001);
    let steps: Vec<Vec<i128>> = cases(&plan, &mut rng, 16)
        .into_iter()
        .map(|c| c.inputs)
        .collect();
    // The arrays the C holds (a table whose differences are read from its samples has no
    // `delta` array) and their bytes.
    let layouts = qloop::emit::table_layouts(&plan);
    let mut arrays = Vec::new();
    let mut bytes = 0u64;
    for (i, (t, l)) in plan.tables.iter().zip(&layouts).enumerate() {
        for (stored, what, bits) in [
            (l.entries, "table", t.format.ty.bits),
            (l.deltas, "delta", t.delta_ty.bits),
        ] {
            if stored {
                arrays.push(format!("tables_{what}_{i}"));
                bytes += l.len as u64 * u64::from(bits) / 8;
            }
        }
    }
    assert!(arrays.len() >= 2, "{arrays:?}");
    for (progmem, flags) in [(true, &[][..]), (false, &["-U__AVR__"][..])] {
        let dir = scratch(&format!("c-tables-avr-flash-{progmem}"));
        let elf = avr::firmware(&plan, cc, &dir, &steps, flags);
        let obj = dir.join("tables.o");
        let (o_syms, e_syms) = (symbols(objdump, &obj), symbols(objdump, &elf));
        let o_secs = sections(size, &obj);
        let sec = |s: &str| o_secs.get(s).copied().unwrap_or(0);
        let lpm = run(Command::new(objdump).arg("-d").arg(&obj))
            .lines()
            .filter(|l| l.contains("\tlpm"))
            .count();
        let mut total = 0;
        for a in &arrays {
            let (o_sec, sz) = o_syms
                .get(a)
                .unwrap_or_else(|| panic!("no `{a}` in the object"));
            let (e_sec, _) = e_syms
                .get(a)
                .unwrap_or_else(|| panic!("no `{a}` in the firmware"));
            total += sz;
            if progmem {
                assert_eq!(o_sec, ".progmem.data", "`{a}` in the object");
                assert_eq!(e_sec, ".text", "`{a}` in the firmware");
            } else {
                assert_eq!(o_sec, ".rodata", "control: `{a}` in the object");
                assert_eq!(e_sec, ".data", "control: `{a}` in the firmware");
            }
        }
        assert_eq!(total, bytes, "array bytes");
        let e_secs = sections(size, &elf);
        let ram =
            e_secs.get(".data").copied().unwrap_or(0) + e_secs.get(".bss").copied().unwrap_or(0);
        if progmem {
            assert_eq!(sec(".progmem.data"), bytes, "{o_secs:?}");
            assert_eq!(sec(".data") + sec(".rodata"), 0, "{o_secs:?}");
            assert!(lpm >= 4, "{lpm} lpm in tables_step");
            assert!(ram < 64, "firmware RAM {ram} bytes: {e_secs:?}");
        } else {
            assert_eq!(sec(".rodata"), bytes, "control: {o_secs:?}");
            assert_eq!(lpm, 0, "control: {lpm} lpm");
            assert!(
                ram >= bytes,
                "control: firmware RAM {ram} bytes: {e_secs:?}"
            );
        }
        println!(
            "avr ({}): arrays {total} B in {}, {lpm} lpm, firmware RAM (.data + .bss) {ram} B, flash {} B",
            if progmem { "PROGMEM" } else { "control -U__AVR__" },
            o_syms[&arrays[0]].0,
            e_secs.get(".text").copied().unwrap_or(0) + e_secs.get(".data").copied().unwrap_or(0)
        );
    }
}

/// The ATmega328P firmware in simavr: every step's raw outputs are the interpreter's, on the
/// knots of both tables and random raw inputs (in flash, so the inputs cost no RAM).
#[test]
fn avr_firmware_in_simavr_matches_the_interpreter() {
    let Some(sim) = avr::Simavr::find() else {
        return;
    };
    let plan = plan_for("atmega328p");
    // Its products' alignments are right shifts of `int64_t`s with 32-bit results, which the
    // AVR C reads from their bytes (`qloop_NAME_sar64`): this run is that helper's on avr-gcc.
    let c = qloop::gen_c(&plan).1;
    assert!(
        c.matches("qloop_tables_sar64(").count() > 2,
        "no sar64 read in the AVR C"
    );
    let mut rng = Rng(0x51a4_0000_0000_0329);
    let cases = cases(&plan, &mut rng, 1_000);
    let n = avr::matches_the_interpreter(&sim, &plan, &cases, &scratch("c-tables-avr-simavr"));
    println!("simavr: {n} steps equal to the interpreter");
}

#[test]
fn fixed_c_matches_the_interpreter_bit_for_bit() {
    let Some(cc) = tool("cc") else { return };
    for t in qloop::targets::builtin() {
        let plan = plan_for(&t.name);
        let dir = scratch(&format!("c-tables-interp-{}", t.name));
        let mut rng = Rng(0x7ab1_e5c0_ffee_0001 ^ t.name.len() as u64);
        let cases = cases(&plan, &mut rng, 4_000);
        let beyond = cases
            .iter()
            .filter(|c| {
                ids(&plan, SigKind::Input)
                    .iter()
                    .zip(&c.inputs)
                    .any(|(id, v)| {
                        let (lo, hi) = plan.bounds(*id);
                        *v < lo || *v > hi
                    })
            })
            .count();
        assert!(beyond > 500, "{}: {beyond} steps beyond the ranges", t.name);
        let n = c_harness::fixed_c_matches_interpreter(&plan, &cc, &dir, &cases);
        println!(
            "{}: {n} steps bit-exact ({beyond} with an input beyond its range)",
            t.name
        );
    }
}

/// Frama-C Eva: 0 alarms for every raw input, host and 16-bit `int` (the ATmega328P's C reads
/// recip's differences as `T[i + 1] − T[i]`). That it checks the table reads: with the index
/// of one read 8 entries on (past the end from index 56 of 64), Eva raises an `index_bound`
/// alarm.
#[test]
fn fixed_c_is_free_of_runtime_errors_by_frama_c_eva() {
    let Some(frama) = tool("frama-c") else { return };
    for (target, machdep) in [("host", "x86_64"), ("atmega328p", "x86_16")] {
        let plan = plan_for(target);
        let dir = scratch(&format!("c-tables-eva-{target}"));
        let out = c_harness::eva(&plan, &frama, machdep, &dir);
        assert!(
            out.contains("No errors or warnings raised"),
            "{target}:\n{out}"
        );

        let c = std::fs::read_to_string(dir.join("tables.c")).unwrap();
        // One read of recip's samples, or two where its differences are read from them.
        let read = "_32(tables_table_0, ";
        let reads = c.matches(read).count();
        let compact = !qloop::emit::table_layouts(&plan)[0].deltas;
        assert_eq!(
            reads,
            1 + usize::from(compact),
            "{target}: reads of recip's samples"
        );
        let bad = dir.join("tables_shifted.c");
        std::fs::write(&bad, c.replacen(read, "_32(tables_table_0, 8 + ", 1)).unwrap();
        let out = c_harness::eva_output(&plan, &frama, machdep, &bad);
        assert!(
            out.contains("index_bound") && !out.contains("0 alarms generated"),
            "{target}: the shifted read raised no alarm:\n{out}"
        );
    }
}

/// The float step against `step_real` from the same (`float`) inputs, 10 % beyond the ranges
/// too. The bound, per output: `x − A` and `·(1/H)` are exact in `float` here (`A` is 0 or 1,
/// `x` a `float` in `[A, B]` with B ≤ 10, so `x − A` has no more significant bits than `x`;
/// `1/H` is a power of two), so are the segment `i` and `t = u − i` and, by Sterbenz, the
/// difference of two neighbouring samples (within a factor 2 of each other). What is left:
/// the samples' rounding to `float` (½ ulp), the product `t·Δ` (½ ulp of Δ) and the sum
/// (½ ulp): at most 1.5 ulp of the largest sample M ≤ 1.5·2^-23·M < 2^-22·M, plus the f64
/// reference's own rounding (~2^-52·M). A read one segment off is off by a whole Δ
/// (≥ 0.002 for recip, ≥ 0.024 for f2), 10^3 times more.
#[test]
fn float_c_matches_the_real_interpreter() {
    let Some(cc) = tool("cc") else { return };
    let plan = plan_for("host");
    let (_, c) = qloop::emit::c_float::source(&plan.prog);
    for want in [
        "static const float tables_samples_0[57] = { 1e0f, 8.888889e-1f, ",
        "static const float tables_samples_1[41] = { ",
        "    x = qloop_minf(qloop_maxf(x, 1e0f), 8e0f);\n",
        "    float u = (x - 1e0f) * 8e0f;\n",
        "    if (i > 55u) i = 55u;\n",
        "    r = tables_table_0(d);\n",
        "    f2 = tables_table_1(eta);\n",
    ] {
        assert!(c.contains(want), "no `{want}` in:\n{c}");
    }
    let tol: Vec<f64> = ids(&plan, SigKind::Output)
        .iter()
        .map(|id| {
            let name = &plan.prog.sig(*id).name;
            let t = LOOKUPS.iter().find(|l| l.2 == name.as_str()).unwrap().1;
            let m = table(&plan, t)
                .samples
                .iter()
                .fold(0f64, |m, s| m.max(s.abs()));
            2f64.powi(-22) * m
        })
        .collect();
    let dir = scratch("c-tables-float");
    let mut rng = Rng(0x5eed_f10a_7ab1_e500);
    let run = c_harness::float_c_matches_real(&plan, &cc, &dir, &mut rng, 4_000, &tol);
    for ((w, t), (.., o)) in run.worst.iter().zip(&tol).zip(&LOOKUPS) {
        println!(
            "float C `{o}`: worst |diff| {w:e} over {} steps (bound {t:e})",
            run.steps
        );
    }
}

/// tables.qloop with its output `r` renamed `rd`: `r` is a halcompile keyword (the direction
/// of a read-only param), which the LinuxCNC emitter refuses as a pin name.
fn renamed() -> String {
    let mut s = SPEC.to_string();
    for (from, to) in [
        ("output r \"1/N\";", "output rd \"1/N\";"),
        (" r = recip(d);", " rd = recip(d);"),
    ] {
        assert_eq!(s.matches(from).count(), 1, "`{from}` in tables.qloop");
        s = s.replace(from, to);
    }
    s
}

#[test]
fn linuxcnc_refuses_the_output_r_and_takes_it_renamed() {
    let msg = qloop::gen_linuxcnc(&plan_for("host"))
        .expect_err("`r` is reserved")
        .to_string();
    assert!(
        msg.contains("output `r`: `r` is reserved in a halcompile component"),
        "{msg}"
    );
    let comp = c_harness::component(&plan_of(&renamed(), "host"));
    for want in [
        "pin out float rd \"The spec's output rd, ",
        "pin out s32 rd_raw ",
        "pin out float f2 ",
        "static const int32_t tables_table_0[64] QLOOP_PROGMEM = {",
    ] {
        assert!(comp.contains(want), "no `{want}` in:\n{comp}");
    }
}

#[test]
fn linuxcnc_component_builds_with_halcompile() {
    let Some(halcompile) = tool("halcompile") else {
        return;
    };
    let dir = scratch("c-tables-halcompile");
    c_harness::halcompile_builds(&plan_of(&renamed(), "host"), &halcompile, &dir);
}

#[test]
fn linuxcnc_glue_and_controller_match_the_interpreter() {
    let Some(cc) = tool("cc") else { return };
    let dir = scratch("c-tables-linuxcnc-ref");
    let mut rng = Rng(0x0c0f_fee0_7ab1_e500);
    c_harness::linuxcnc_matches_interpreter(
        &plan_of(&renamed(), "host"),
        &cc,
        &dir,
        &mut rng,
        3_000,
    );
}
