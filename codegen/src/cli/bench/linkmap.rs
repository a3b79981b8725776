//! Reading a GNU ld link map (`-Wl,-Map=link.map`): the archive members the link pulled in,
//! the memory regions, and which input file put how many bytes into which output section.

/// An archive member the link included: the archive's path and the member's name
/// (`/usr/lib/gcc/avr/5.4.0/avr5/libgcc.a`, `_mulsi3.o`).
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub(super) struct Member {
    /// The archive as the map names it.
    pub(super) archive: String,
    /// The member's file name inside it.
    pub(super) name: String,
}

/// A memory region of the link (`MEMORY { text : ORIGIN = 0, LENGTH = 32K }`).
#[derive(Clone, Debug, PartialEq, Eq)]
pub(super) struct Region {
    /// Its name (`text`, `data`, `FLASH`, `RAM`).
    pub(super) name: String,
    /// Its length in bytes.
    pub(super) length: u64,
}

/// Bytes an input file put into an output section (one line of the memory map).
#[derive(Clone, Debug, PartialEq, Eq)]
pub(super) struct Input {
    /// The output section (`.text`, `.data`).
    pub(super) section: String,
    /// The file as the map names it: a path, or `archive(member)`.
    pub(super) file: String,
    /// Bytes, after linking (relaxation included).
    pub(super) size: u64,
}

/// What [`parse`] reads from a map.
#[derive(Clone, Debug, Default, PartialEq)]
pub(super) struct LinkMap {
    /// The members of "Archive member included to satisfy reference by file (symbol)", in
    /// the map's order.
    pub(super) members: Vec<Member>,
    /// The regions of "Memory Configuration" (without ld's `*default*`).
    pub(super) regions: Vec<Region>,
    /// The input sections of "Linker script and memory map" with a file and a size
    /// (`*fill*` and linker-made bytes have no file and are left out).
    pub(super) inputs: Vec<Input>,
}

impl LinkMap {
    /// The length of the region called `name`, if the link had one.
    pub(super) fn region(&self, name: &str) -> Option<u64> {
        self.regions
            .iter()
            .find(|r| r.name == name)
            .map(|r| r.length)
    }
}

/// `archive(member)` as the map prints an included member, split.
pub(super) fn member_of(token: &str) -> Option<Member> {
    let inner = token.strip_suffix(')')?;
    let open = inner.rfind('(')?;
    let (archive, name) = (&inner[..open], &inner[open + 1..]);
    (!archive.is_empty() && !name.is_empty()).then(|| Member {
        archive: archive.to_string(),
        name: name.to_string(),
    })
}

/// A number as the map prints it (`0x0000000000008000`).
fn hex(s: &str) -> Option<u64> {
    u64::from_str_radix(s.strip_prefix("0x")?, 16).ok()
}

/// Reads the included archive members, the memory regions and the input sections from the
/// text of a GNU ld map. Anything else in the map is ignored; a map without these parts gives
/// empty lists.
pub(super) fn parse(text: &str) -> LinkMap {
    #[derive(PartialEq)]
    enum Part {
        Other,
        Members,
        Regions,
        Sections,
    }
    let mut part = Part::Other;
    let mut map = LinkMap::default();
    // In the memory map: the current output section, and an input section whose name stood
    // alone on its line (long names), waiting for its address, size and file.
    let mut out: Option<String> = None;
    let mut pending = false;
    for line in text.lines() {
        if line.starts_with("Linker script and memory map") {
            part = Part::Sections;
            continue;
        }
        if line.starts_with("Archive member included") {
            part = Part::Members;
            continue;
        }
        if line.starts_with("Memory Configuration") {
            part = Part::Regions;
            continue;
        }
        if line.starts_with("Discarded input sections")
            || line.starts_with("Allocating common symbols")
        {
            part = Part::Other;
            continue;
        }
        match part {
            Part::Members => {
                // `archive(member)` at the start of a line, then (on it or the next, indented)
                // the file and symbol that pulled it in.
                if !line.starts_with(char::is_whitespace) {
                    if let Some(m) = line.split_whitespace().next().and_then(member_of) {
                        map.members.push(m);
                    }
                }
            }
            Part::Regions => {
                let f: Vec<&str> = line.split_whitespace().collect();
                if let [name, origin, length, ..] = f.as_slice() {
                    if *name != "*default*" && hex(origin).is_some() {
                        if let Some(length) = hex(length) {
                            map.regions.push(Region {
                                name: name.to_string(),
                                length,
                            });
                        }
                    }
                }
            }
            Part::Sections => {
                let f: Vec<&str> = line.split_whitespace().collect();
                if !line.starts_with(char::is_whitespace) {
                    // An output section (`.text  0x0  0xa00`), or LOAD, OUTPUT, GROUP lines.
                    out = f
                        .first()
                        .filter(|n| n.starts_with('.'))
                        .map(|n| n.to_string());
                    pending = false;
                    continue;
                }
                let Some(sec) = &out else { continue };
                let is_input = line.starts_with(' ')
                    && !line.starts_with("  ")
                    && f.first()
                        .is_some_and(|n| !n.starts_with('*') || *n == "COMMON");
                let rest: &[&str] = if is_input && f.len() == 1 {
                    pending = true;
                    continue;
                } else if is_input {
                    pending = false;
                    &f[1..]
                } else if std::mem::take(&mut pending) {
                    &f[..]
                } else {
                    continue;
                };
                if let [addr, size, file @ ..] = rest {
                    if let (Some(_), Some(size), false) = (hex(addr), hex(size), file.is_empty()) {
                        map.inputs.push(Input {
                            section: sec.clone(),
                            file: file.join(" "),
                            size,
                        });
                    }
                }
            }
            Part::Other => {}
        }
    }
    map
}

#[cfg(test)]
mod tests {
    use super::*;

    const MAP: &str = "Archive member included to satisfy reference by file (symbol)

/usr/lib/gcc/avr/5.4.0/avr5/libgcc.a(_exit.o)
                              /usr/lib/avr/lib/avr5/crtatmega328p.o (exit)
/usr/lib/avr/lib/avr5/libm.a(addsf3.o)
                              ctrl.o (__subsf3)
x.a(m.o)                      main.o (f)

Discarded input sections

 .text          0x0000000000000000        0x0 main.o

Memory Configuration

Name             Origin             Length             Attributes
text             0x0000000000000000 0x0000000000008000 xr
data             0x0000000000800100 0x0000000000000800 rw !x
*default*        0x0000000000000000 0xffffffffffffffff

Linker script and memory map

LOAD main.o
                [0x0000000000008000]                __TEXT_REGION_LENGTH__ = DEFINED (__TEXT_REGION_LENGTH__)?__TEXT_REGION_LENGTH__:0x20000

.text           0x0000000000000000      0xa00
 *(.vectors)
 .vectors       0x0000000000000000       0x68 /usr/lib/avr/lib/avr5/crtatmega328p.o
                0x0000000000000000                __vectors
 .text          0x00000000000003b0      0x2c8 /w/float/ctrl.o
                0x00000000000003b0                k_init
 .text.avr-libc.fplib
                0x00000000000008c6       0x44 /usr/lib/avr/lib/avr5/libm.a(fp_split3.o)
                0x00000000000008c6                __fp_split3
 *fill*         0x000000000000090a        0x2 
 .text          0x000000000000090c        0x0 main.o
                0x0000000000000a00                _etext = .

.data           0x0000000000800100       0x10 load address 0x0000000000000a00
 *(.rodata)
 .rodata        0x0000000000800100       0x10 /w/float/ctrl.o

.bss            0x0000000000800110        0x4
 COMMON         0x0000000000800110        0x4 main.o
OUTPUT(float.elf elf32-avr)
";

    #[test]
    fn reads_members_and_regions() {
        let m = parse(MAP);
        let names: Vec<(&str, &str)> = m
            .members
            .iter()
            .map(|m| (m.archive.as_str(), m.name.as_str()))
            .collect();
        assert_eq!(
            names,
            [
                ("/usr/lib/gcc/avr/5.4.0/avr5/libgcc.a", "_exit.o"),
                ("/usr/lib/avr/lib/avr5/libm.a", "addsf3.o"),
                ("x.a", "m.o"),
            ]
        );
        assert_eq!(m.region("text"), Some(0x8000));
        assert_eq!(m.region("data"), Some(0x800));
        assert_eq!(m.region("*default*"), None);
        assert_eq!(m.regions.len(), 2);
        let inputs: Vec<(&str, &str, u64)> = m
            .inputs
            .iter()
            .map(|i| (i.section.as_str(), i.file.as_str(), i.size))
            .collect();
        assert_eq!(
            inputs,
            [
                (".text", "/usr/lib/avr/lib/avr5/crtatmega328p.o", 0x68),
                (".text", "/w/float/ctrl.o", 0x2c8),
                (".text", "/usr/lib/avr/lib/avr5/libm.a(fp_split3.o)", 0x44),
                (".text", "main.o", 0),
                (".data", "/w/float/ctrl.o", 0x10),
                (".bss", "main.o", 4),
            ]
        );
    }

    #[test]
    fn an_empty_map_has_nothing() {
        assert_eq!(parse(""), LinkMap::default());
    }
}
