//! Flash and RAM of a variant: the whole ELF, and the controller's own share of it.
//!
//! * Whole ELF: the target's `size` (Berkeley format) on the linked firmware: flash =
//!   text + data, RAM = data + bss. This is the benchmark firmware: harness (`main.c`), the
//!   input table (in flash), startup code and the result reporting as well as the controller.
//! * Controller: what the link map says the variant's own objects (its `.c` files, compiled
//!   on their own: `step`, `init`, static helpers, tables) put into the firmware, plus every
//!   library archive member the link pulled in that they need: the members defining a
//!   symbol the objects leave undefined, then, to a fixed point, those the members themselves
//!   need (`nm` on the archives). That is `__muldi3`, soft-float and the like, counted whole
//!   (no `--gc-sections`). Each input section counts as text, data or bss by the output
//!   section the linker put it in (flags from `objdump -h`, classed as `size` does), so
//!   constants that the AVR keeps in RAM (`.rodata` lands in `.data` there) count as RAM,
//!   and sizes are after linker relaxation (RISC-V). Its RAM adds the state object
//!   (`bench_state` in `main.c`, its size from the ELF's `nm`). Inputs and outputs
//!   (`bench_in`, `bench_out`) are the harness's, not counted.
//! * Step frame: the stack frame of `P_step` itself (`-fstack-usage`), without the frames
//!   of the library routines it calls.

use super::compile::Build;
use super::host::need_tool;
use super::linkmap::{self, Member};
use super::platform::Platform;
use crate::cli::error::{CliError, CliResult};
use std::collections::{BTreeSet, HashMap};
use std::path::Path;
use std::process::Command;

/// Berkeley sizes of a file or a sum of files, in bytes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(super) struct Berkeley {
    /// Code and read-only data.
    pub(super) text: u64,
    /// Initialised data: stored in flash, copied to RAM.
    pub(super) data: u64,
    /// Zeroed data.
    pub(super) bss: u64,
}

impl Berkeley {
    /// Flash: text + data.
    pub(super) fn flash(self) -> u64 {
        self.text + self.data
    }
    /// Static RAM: data + bss.
    pub(super) fn ram(self) -> u64 {
        self.data + self.bss
    }
    /// Adds `n` bytes of class `c`.
    fn add(&mut self, c: Class, n: u64) {
        match c {
            Class::Text => self.text += n,
            Class::Data => self.data += n,
            Class::Bss => self.bss += n,
            Class::None => {}
        }
    }
}

/// Where `size` counts an output section: code and read-only data, initialised data, zeroed
/// data, or nowhere (not allocated: debug information, comments).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Class {
    Text,
    Data,
    Bss,
    None,
}

/// The class of every output section of an ELF from `objdump -h`, as binutils' `size`
/// decides it (Berkeley format): not ALLOC → none; CODE or READONLY → text; CONTENTS →
/// data; else bss.
fn classes(objdump_h: &str) -> HashMap<String, Class> {
    let mut out = HashMap::new();
    let mut name: Option<String> = None;
    for line in objdump_h.lines() {
        let f: Vec<&str> = line.split_whitespace().collect();
        if f.len() >= 3 && f[0].parse::<u32>().is_ok() {
            name = Some(f[1].to_string());
            continue;
        }
        let Some(n) = name.take() else { continue };
        let flags: Vec<&str> = line.split(',').map(str::trim).collect();
        let has = |x: &str| flags.contains(&x);
        let c = if !has("ALLOC") {
            Class::None
        } else if has("CODE") || has("READONLY") {
            Class::Text
        } else if has("CONTENTS") {
            Class::Data
        } else {
            Class::Bss
        };
        out.insert(n, c);
    }
    out
}

/// The target toolchain's `size`, `nm` and `objdump`.
pub(super) struct SizeTools {
    size: String,
    nm: String,
    objdump: String,
}

/// The target's `size`, `nm` and `objdump`, named after its compiler (`avr-gcc` →
/// `avr-size`, `avr-nm`, `avr-objdump`); fails with an install hint unless all run.
pub(super) fn tools(t: &qloop::Target, pf: &Platform) -> CliResult<SizeTools> {
    let cc = t.toolchain.cc.clone().unwrap_or_default();
    let Some(prefix) = cc.strip_suffix("gcc") else {
        return Err(CliError::input(format!(
            "target `{}`: `qloop bench` finds `size`, `nm` and `objdump` next to a GCC compiler (`avr-gcc` → \
             `avr-size`), but `[toolchain] cc` is `{cc}`",
            t.name
        )));
    };
    let hint = match pf {
        Platform::Avr => "Debian: apt-get install binutils-avr",
        Platform::Qemu { .. } => "Debian: apt-get install binutils-arm-none-eabi",
        Platform::Riscv { .. } => "Debian: apt-get install binutils-riscv64-unknown-elf",
    };
    let tools = SizeTools {
        size: format!("{prefix}size"),
        nm: format!("{prefix}nm"),
        objdump: format!("{prefix}objdump"),
    };
    for tool in [&tools.size, &tools.nm, &tools.objdump] {
        need_tool(
            tool,
            &format!("it measures flash and RAM of the firmware ({hint})"),
        )?;
    }
    Ok(tools)
}

/// A variant's flash and RAM, whole and the controller's, and the memory it has.
#[derive(Clone, Debug, Default, PartialEq)]
pub(super) struct Footprint {
    /// The whole ELF.
    pub(super) elf: Berkeley,
    /// What the controller's own objects put into the firmware.
    pub(super) own: Berkeley,
    /// The library members they need (see the module docs), and their names.
    pub(super) lib: Berkeley,
    pub(super) lib_members: Vec<String>,
    /// Size of the state object.
    pub(super) state: u64,
    /// Size of the step function in the ELF.
    pub(super) step: Option<u64>,
    /// The step function's own stack frame and its `-fstack-usage` qualifier (`static`,
    /// `dynamic,bounded`), if reported.
    pub(super) frame: Option<(u64, String)>,
    /// The controller objects' defined symbols with a size: name, `nm` type, bytes (in the
    /// object: before linker relaxation on RISC-V); largest first.
    pub(super) symbols: Vec<(String, char, u64)>,
    /// Flash and RAM of the link's memory regions, if the link map names them.
    pub(super) flash_limit: Option<u64>,
    pub(super) ram_limit: Option<u64>,
    /// The linker's complaint when the sections did not fit its memory regions.
    pub(super) overflow: Option<String>,
}

impl Footprint {
    /// Controller flash: own objects and library members.
    pub(super) fn ctrl_flash(&self) -> u64 {
        self.own.flash() + self.lib.flash()
    }
    /// Controller RAM: the state and the static data of its objects and members.
    pub(super) fn ctrl_ram(&self) -> u64 {
        self.own.ram() + self.lib.ram() + self.state
    }
    /// Whether the ELF fits the target's memory: `Some(reasons)` (empty when it fits), or
    /// `None` when the link map gave no limits and the linker did not complain. RAM must
    /// hold the static data and the step's own frame (a lower bound of its stack).
    pub(super) fn misfits(&self) -> Option<Vec<String>> {
        let mut why = Vec::new();
        if let Some(flash) = self.flash_limit {
            if self.elf.flash() > flash {
                why.push(format!("flash {} > {flash}", self.elf.flash()));
            }
        }
        if let Some(ram) = self.ram_limit {
            let frame = self.frame.as_ref().map_or(0, |f| f.0);
            if self.elf.ram() > ram {
                why.push(format!("RAM {} > {ram}", self.elf.ram()));
            } else if self.elf.ram() + frame > ram {
                why.push(format!(
                    "RAM {} + step frame {frame} = {} > {ram}",
                    self.elf.ram(),
                    self.elf.ram() + frame
                ));
            }
        }
        if why.is_empty() {
            if let Some(o) = &self.overflow {
                why.push(format!("the linker: {o}"));
            } else if self.flash_limit.is_none() || self.ram_limit.is_none() {
                return None;
            }
        }
        Some(why)
    }
}

/// Runs `tool args file` in `dir` (the map names files relative to the link's directory)
/// and returns its standard output.
fn output(tool: &str, args: &[&str], file: &Path, dir: &Path) -> CliResult<String> {
    let out = Command::new(tool)
        .current_dir(dir)
        .args(args)
        .arg(file)
        .output()
        .map_err(|e| CliError::tool(format!("cannot run `{tool}`: {e}")))?;
    if !out.status.success() {
        return Err(CliError::tool(format!(
            "`{tool} {} {}` failed: {}",
            args.join(" "),
            file.display(),
            String::from_utf8_lossy(&out.stderr).trim()
        )));
    }
    Ok(String::from_utf8_lossy(&out.stdout).into_owned())
}

/// The rows of `size` in Berkeley format: file name (for an archive, the member's, without
/// ` (ex ARCHIVE)`) and sizes.
fn berkeley_rows(text: &str) -> Vec<(String, Berkeley)> {
    text.lines()
        .filter_map(|l| {
            let f: Vec<&str> = l.split_whitespace().collect();
            let n = |i: usize| f.get(i).and_then(|s| s.parse::<u64>().ok());
            let b = Berkeley {
                text: n(0)?,
                data: n(1)?,
                bss: n(2)?,
            };
            let name = f.get(5..).map(|r| r.join(" ")).unwrap_or_default();
            let name = match name.find(" (ex ") {
                Some(i) => name[..i].to_string(),
                None => name,
            };
            Some((name, b))
        })
        .collect()
}

/// One symbol from `nm -P -t d`: member (for `nm -A` on an archive), name, type, size.
struct Sym {
    member: Option<String>,
    name: String,
    kind: char,
    size: Option<u64>,
}

impl Sym {
    /// An undefined reference.
    fn undefined(&self) -> bool {
        self.kind == 'U'
    }
    /// A definition other objects can link to.
    fn global(&self) -> bool {
        self.kind.is_ascii_uppercase() && !matches!(self.kind, 'U' | 'A')
    }
}

/// The symbols of `nm -P -t d` (with `-A`: `archive[member]: name type value size`).
fn nm_rows(text: &str) -> Vec<Sym> {
    text.lines()
        .filter_map(|l| {
            let (member, rest) = match l.split_once("]: ") {
                Some((head, rest)) => (head.rsplit_once('[').map(|(_, m)| m.to_string()), rest),
                None => (None, l),
            };
            let f: Vec<&str> = rest.split_whitespace().collect();
            let kind = f.get(1)?.chars().next()?;
            Some(Sym {
                member,
                name: f.first()?.to_string(),
                kind,
                size: f.get(3).and_then(|s| s.parse().ok()),
            })
        })
        .collect()
}

/// The library members `undefined` needs, to a fixed point, among those the link included.
fn needed_members(
    tools: &SizeTools,
    dir: &Path,
    included: &[Member],
    undefined: BTreeSet<String>,
) -> CliResult<BTreeSet<Member>> {
    let archives: BTreeSet<&str> = included.iter().map(|m| m.archive.as_str()).collect();
    let inc: BTreeSet<&Member> = included.iter().collect();
    let mut defines: HashMap<String, Vec<Member>> = HashMap::new();
    let mut needs: HashMap<Member, Vec<String>> = HashMap::new();
    for a in archives {
        for s in nm_rows(&output(
            &tools.nm,
            &["-A", "-P", "-t", "d"],
            Path::new(a),
            dir,
        )?) {
            let Some(name) = s.member.clone() else {
                continue;
            };
            let m = Member {
                archive: a.to_string(),
                name,
            };
            if !inc.contains(&m) {
                continue;
            }
            if s.undefined() {
                needs.entry(m).or_default().push(s.name);
            } else if s.global() {
                defines.entry(s.name).or_default().push(m);
            }
        }
    }
    let mut seen = BTreeSet::new();
    let mut todo: Vec<String> = undefined.into_iter().collect();
    let mut asked = BTreeSet::new();
    while let Some(sym) = todo.pop() {
        if !asked.insert(sym.clone()) {
            continue;
        }
        for m in defines.get(&sym).into_iter().flatten() {
            if seen.insert(m.clone()) {
                todo.extend(needs.get(m).into_iter().flatten().cloned());
            }
        }
    }
    Ok(seen)
}

/// Measures a built variant (see the module docs); `step` is the name of its step function.
pub(super) fn footprint(
    tools: &SizeTools,
    b: &Build,
    pf: &Platform,
    step: &str,
) -> CliResult<Footprint> {
    let dir = b.elf.parent().unwrap_or(Path::new("."));
    let one = |file: &Path| -> CliResult<Berkeley> {
        berkeley_rows(&output(&tools.size, &["-B"], file, dir)?)
            .first()
            .map(|r| r.1)
            .ok_or_else(|| {
                CliError::tool(format!(
                    "`{} -B {}` printed no sizes",
                    tools.size,
                    file.display()
                ))
            })
    };
    let mut f = Footprint {
        elf: one(&b.elf)?,
        overflow: b.overflow.clone(),
        ..Footprint::default()
    };
    let mut undefined = BTreeSet::new();
    for o in &b.objects {
        for s in nm_rows(&output(&tools.nm, &["-P", "-t", "d"], o, dir)?) {
            if s.undefined() {
                undefined.insert(s.name);
            } else if let Some(size) = s.size.filter(|n| *n > 0) {
                f.symbols.push((s.name, s.kind, size));
            }
        }
    }
    f.symbols
        .sort_by(|a, b| b.2.cmp(&a.2).then_with(|| a.0.cmp(&b.0)));

    let map_text = std::fs::read_to_string(&b.map).map_err(|e| {
        CliError::tool(format!(
            "cannot read the link map `{}`: {e}",
            b.map.display()
        ))
    })?;
    let map = linkmap::parse(&map_text);
    let (flash_region, ram_region) = pf.regions();
    f.flash_limit = map.region(flash_region);
    f.ram_limit = map.region(ram_region);

    let members = needed_members(tools, dir, &map.members, undefined)?;
    f.lib_members = members.iter().map(|m| m.name.clone()).collect();
    let class = classes(&output(&tools.objdump, &["-h"], &b.elf, dir)?);
    for i in &map.inputs {
        let c = class.get(&i.section).copied().unwrap_or(Class::None);
        if b.objects.iter().any(|o| Path::new(&i.file) == o) {
            f.own.add(c, i.size);
        } else if linkmap::member_of(&i.file).is_some_and(|m| members.contains(&m)) {
            f.lib.add(c, i.size);
        }
    }

    let elf_syms = nm_rows(&output(&tools.nm, &["-P", "-t", "d"], &b.elf, dir)?);
    let size_of = |name: &str| {
        elf_syms
            .iter()
            .find(|s| s.name == name && !s.undefined())
            .and_then(|s| s.size)
    };
    f.step = size_of(step);
    f.state = size_of("bench_state").ok_or_else(|| {
        CliError::tool(format!(
            "no size for the state object `bench_state` in `{} -P {}`",
            tools.nm,
            b.elf.display()
        ))
    })?;
    f.frame = b.stack_usage.iter().find_map(|su| {
        std::fs::read_to_string(su)
            .ok()
            .and_then(|t| frame_of(&t, step))
    });
    Ok(f)
}

/// The frame of function `name` in a `-fstack-usage` file (`file:line:col:name<TAB>bytes<TAB>
/// qualifier`).
fn frame_of(su: &str, name: &str) -> Option<(u64, String)> {
    su.lines().find_map(|l| {
        let f: Vec<&str> = l.split('\t').collect();
        let func = f.first()?.rsplit(':').next()?;
        (func == name).then_some(())?;
        Some((f.get(1)?.trim().parse().ok()?, f.get(2)?.trim().to_string()))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn berkeley_rows_of_a_file_and_an_archive() {
        let elf = "   text\t   data\t    bss\t    dec\t    hex\tfilename\n   2560\t      0\t     20\t   2580\t    a14\tfloat.elf\n";
        assert_eq!(
            berkeley_rows(elf),
            [(
                "float.elf".to_string(),
                Berkeley {
                    text: 2560,
                    data: 0,
                    bss: 20
                }
            )]
        );
        let ar = "   text\t   data\t    bss\t    dec\t    hex\tfilename\n     18\t      0\t      0\t     18\t     12\t_absvhi2.o (ex /usr/lib/gcc/avr/5.4.0/avr5/libgcc.a)\n";
        let rows = berkeley_rows(ar);
        assert_eq!(rows[0].0, "_absvhi2.o");
        assert_eq!(rows[0].1.flash(), 18);
    }

    #[test]
    fn nm_rows_with_and_without_archive_members() {
        let s = nm_rows(
            "/x/libgcc.a[_mulsi3.o]: __mulsi3 T 0 70\n/x/libgcc.a[_mulsi3.o]: __foo U \nbench_state b 8388872 12\n",
        );
        assert_eq!(s.len(), 3);
        assert_eq!(s[0].member.as_deref(), Some("_mulsi3.o"));
        assert!(s[0].global() && !s[0].undefined());
        assert_eq!(s[0].size, Some(70));
        assert!(s[1].undefined());
        assert_eq!(s[2].member, None);
        assert!(!s[2].global());
        assert_eq!(s[2].size, Some(12));
    }

    #[test]
    fn output_sections_are_classed_as_size_does() {
        let h = "\nfloat.elf:     file format elf32-avr\n\nSections:\n\
                 Idx Name          Size      VMA       LMA       File off  Algn\n\
                 \x20 0 .data         00000000  00800100  00000a00  00000a94  2**0\n\
                 \x20                 CONTENTS, ALLOC, LOAD, DATA\n\
                 \x20 1 .text         00000a00  00000000  00000000  00000094  2**1\n\
                 \x20                 CONTENTS, ALLOC, LOAD, READONLY, CODE\n\
                 \x20 2 .bss          00000014  00800100  00800100  00000a94  2**0\n\
                 \x20                 ALLOC\n\
                 \x20 3 .comment      00000011  00000000  00000000  00000a94  2**0\n\
                 \x20                 CONTENTS, READONLY\n";
        let c = classes(h);
        assert_eq!(c[".data"], Class::Data);
        assert_eq!(c[".text"], Class::Text);
        assert_eq!(c[".bss"], Class::Bss);
        assert_eq!(c[".comment"], Class::None);
        assert_eq!(c.len(), 4);
    }

    #[test]
    fn stack_frame_of_the_step() {
        let su = "k.c:17:6:k_init\t2\tstatic\nk.c:24:6:k_step\t30\tstatic\n";
        assert_eq!(frame_of(su, "k_step"), Some((30, "static".to_string())));
        assert_eq!(frame_of(su, "k_other"), None);
    }

    #[test]
    fn misfits_name_the_memory_that_is_short() {
        let mut f = Footprint {
            elf: Berkeley {
                text: 40000,
                data: 10,
                bss: 100,
            },
            frame: Some((2000, "static".into())),
            ..Footprint::default()
        };
        assert_eq!(f.misfits(), None, "no limits, no verdict");
        f.flash_limit = Some(32768);
        f.ram_limit = Some(2048);
        assert_eq!(
            f.misfits(),
            Some(vec![
                "flash 40010 > 32768".to_string(),
                "RAM 110 + step frame 2000 = 2110 > 2048".to_string()
            ])
        );
        f.elf.text = 100;
        f.frame = None;
        assert_eq!(f.misfits(), Some(vec![]));
        f.flash_limit = None;
        assert_eq!(f.misfits(), None);
        f.overflow = Some("region `text' overflowed by 4 bytes".into());
        assert_eq!(
            f.misfits(),
            Some(vec![
                "the linker: region `text' overflowed by 4 bytes".to_string()
            ])
        );
    }
}
