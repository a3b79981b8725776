//! Physical units: the unit strings of a spec (`"kN"`, `"(mm/s)/kN"`, `"rpm"`, `"%"`) parsed
//! into a dimension (exponents over the SI base units plus the revolution) and a scale to the
//! coherent unit of that dimension.
//!
//! The algebra is small on purpose: the runtime unit crates (`dyn_quantity`,
//! `dimensional_analyser`) know neither the machining units (`rpm`, `rev`, `%`, `mm/rev`) nor
//! how to point at the wrong character of a spec, and the compiler core, which the proc-macro
//! links, stays free of heavy dependencies.
//!
//! Grammar: `unit := term (('*' | '·' | '/') term)*`, left-associative;
//! `term := factor ('^' INT | '²' | '³')?`; `factor := '(' unit ')' | '1' | SYMBOL`. A symbol
//! is a base unit (table [`BASES`]), optionally with an SI prefix (`n µ u m c d k M G`) where
//! the base takes prefixes. The empty string and `"1"` are dimensionless.
//!
//! The revolution is a base dimension of its own, so that a feed per revolution (`mm/rev`)
//! and a feed per time (`mm/s`) cannot be confused, and `rpm` is `rev/min`; `rad` and `deg`
//! are fractions of a revolution.

use std::fmt;

/// Number of base dimensions.
pub const BASE_DIMS: usize = 8;
/// The base dimensions' symbols, in [`Unit::dims`] order.
pub const BASE_SYMBOLS: [&str; BASE_DIMS] = ["kg", "m", "s", "A", "K", "mol", "cd", "rev"];

/// A unit: `scale` times the coherent SI unit of dimension `dims` (exponents in
/// [`BASE_SYMBOLS`] order). `kN` is `1000 · kg·m·s⁻²`; `%` is `0.01` (dimensionless).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Unit {
    /// Factor to the coherent unit.
    pub scale: f64,
    /// Exponents of the base dimensions.
    pub dims: [i8; BASE_DIMS],
}

/// A base unit symbol: name, scale, dimensions, whether it takes SI prefixes.
type Base = (&'static str, f64, [i8; BASE_DIMS], bool);

/// The base unit symbols a unit string may use (with an SI prefix where the last field is
/// `true`).
pub const BASES: &[Base] = &[
    ("g", 1e-3, [1, 0, 0, 0, 0, 0, 0, 0], true),
    ("m", 1.0, [0, 1, 0, 0, 0, 0, 0, 0], true),
    ("s", 1.0, [0, 0, 1, 0, 0, 0, 0, 0], true),
    ("A", 1.0, [0, 0, 0, 1, 0, 0, 0, 0], true),
    ("K", 1.0, [0, 0, 0, 0, 1, 0, 0, 0], false),
    ("mol", 1.0, [0, 0, 0, 0, 0, 1, 0, 0], true),
    ("cd", 1.0, [0, 0, 0, 0, 0, 0, 1, 0], false),
    ("rev", 1.0, [0, 0, 0, 0, 0, 0, 0, 1], false),
    (
        "rad",
        1.0 / std::f64::consts::TAU,
        [0, 0, 0, 0, 0, 0, 0, 1],
        true,
    ),
    ("deg", 1.0 / 360.0, [0, 0, 0, 0, 0, 0, 0, 1], false),
    ("rpm", 1.0 / 60.0, [0, 0, -1, 0, 0, 0, 0, 1], false),
    ("min", 60.0, [0, 0, 1, 0, 0, 0, 0, 0], false),
    ("h", 3600.0, [0, 0, 1, 0, 0, 0, 0, 0], false),
    ("Hz", 1.0, [0, 0, -1, 0, 0, 0, 0, 0], true),
    ("N", 1.0, [1, 1, -2, 0, 0, 0, 0, 0], true),
    ("J", 1.0, [1, 2, -2, 0, 0, 0, 0, 0], true),
    ("W", 1.0, [1, 2, -3, 0, 0, 0, 0, 0], true),
    ("Pa", 1.0, [1, -1, -2, 0, 0, 0, 0, 0], true),
    ("V", 1.0, [1, 2, -3, -1, 0, 0, 0, 0], true),
    ("Ohm", 1.0, [1, 2, -3, -2, 0, 0, 0, 0], true),
    ("in", 0.0254, [0, 1, 0, 0, 0, 0, 0, 0], false),
    ("%", 0.01, [0; BASE_DIMS], false),
];

/// SI prefixes: symbol and factor. `u` is accepted for `µ`.
const PREFIXES: &[(&str, f64)] = &[
    ("n", 1e-9),
    ("µ", 1e-6),
    ("μ", 1e-6),
    ("u", 1e-6),
    ("m", 1e-3),
    ("c", 1e-2),
    ("d", 1e-1),
    ("k", 1e3),
    ("M", 1e6),
    ("G", 1e9),
];

/// Names of common dimensions, for messages.
const DIM_NAMES: &[([i8; BASE_DIMS], &str)] = &[
    ([0; BASE_DIMS], "dimensionless"),
    ([1, 1, -2, 0, 0, 0, 0, 0], "force"),
    ([1, 2, -3, 0, 0, 0, 0, 0], "power"),
    ([1, 2, -2, 0, 0, 0, 0, 0], "energy or torque"),
    ([0, 1, 0, 0, 0, 0, 0, 0], "length"),
    ([0, 0, 1, 0, 0, 0, 0, 0], "time"),
    ([0, 1, -1, 0, 0, 0, 0, 0], "velocity"),
    ([0, 0, -1, 0, 0, 0, 0, 0], "frequency"),
    ([0, 0, -1, 0, 0, 0, 0, 1], "rotational speed"),
    ([0, 0, 0, 0, 0, 0, 0, 1], "angle"),
    ([0, 1, 0, 0, 0, 0, 0, -1], "feed per revolution"),
    ([1, 0, -2, 0, 0, 0, 0, 0], "force per length"),
    ([1, 0, -1, 0, 0, 0, 0, 0], "force per velocity"),
    ([-1, 0, 1, 0, 0, 0, 0, 0], "velocity per force"),
    ([1, 2, -3, -1, 0, 0, 0, 0], "voltage"),
    ([0, 0, 0, 1, 0, 0, 0, 0], "current"),
    ([1, -1, -2, 0, 0, 0, 0, 0], "pressure"),
];

impl Unit {
    /// The dimensionless unit 1.
    pub const ONE: Unit = Unit {
        scale: 1.0,
        dims: [0; BASE_DIMS],
    };

    /// The second.
    pub const SECOND: Unit = Unit {
        scale: 1.0,
        dims: [0, 0, 1, 0, 0, 0, 0, 0],
    };

    /// `self ^ n`.
    pub fn powi(self, n: i8) -> Unit {
        let mut dims = self.dims;
        for d in &mut dims {
            *d = d.saturating_mul(n);
        }
        Unit {
            scale: self.scale.powi(n as i32),
            dims,
        }
    }

    /// Same dimension (possibly a different scale: `N` and `kN`).
    pub fn same_dimension(&self, other: &Unit) -> bool {
        self.dims == other.dims
    }

    /// Same dimension and scale, up to the rounding of the scales' products (`(mm/s)/kN`
    /// and `mm/(s·kN)` are the same unit).
    pub fn same(&self, other: &Unit) -> bool {
        self.same_dimension(other) && (self.scale / other.scale - 1.0).abs() <= 1e-12
    }

    /// Dimensionless (a pure number, possibly scaled: `%`).
    pub fn is_dimensionless(&self) -> bool {
        self.dims == [0; BASE_DIMS]
    }

    /// The factor that converts a value in `self` to a value in `to`: `x [self] =
    /// x · factor [to]`. `None` if the dimensions differ.
    pub fn factor_to(&self, to: &Unit) -> Option<f64> {
        self.same_dimension(to).then(|| self.scale / to.scale)
    }

    /// The dimension's common name (`force`, `velocity`), if it has one.
    pub fn dimension_name(&self) -> Option<&'static str> {
        DIM_NAMES
            .iter()
            .find(|(d, _)| *d == self.dims)
            .map(|(_, n)| *n)
    }

    /// The dimension in SI base units, `kg·m·s^-2` (`1` if dimensionless).
    pub fn dimension_text(&self) -> String {
        let parts: Vec<String> = BASE_SYMBOLS
            .iter()
            .zip(self.dims)
            .filter(|(_, e)| *e != 0)
            .map(|(s, e)| {
                if e == 1 {
                    s.to_string()
                } else {
                    format!("{s}^{e}")
                }
            })
            .collect();
        if parts.is_empty() {
            "1".into()
        } else {
            parts.join("·")
        }
    }
}

impl std::ops::Mul for Unit {
    type Output = Unit;

    /// The product unit: exponents add, scales multiply.
    fn mul(self, other: Unit) -> Unit {
        let mut dims = self.dims;
        for (d, o) in dims.iter_mut().zip(other.dims) {
            *d = d.saturating_add(o);
        }
        Unit {
            scale: self.scale * other.scale,
            dims,
        }
    }
}

impl std::ops::Div for Unit {
    type Output = Unit;

    /// The quotient unit.
    fn div(self, other: Unit) -> Unit {
        self * other.powi(-1)
    }
}

impl fmt::Display for Unit {
    /// `1000·kg·m·s^-2`, the scale omitted when it is 1.
    fn fmt(&self, f: &mut fmt::Formatter) -> fmt::Result {
        let d = self.dimension_text();
        let e = self.scale.log10().round();
        let scale = if (self.scale / 10f64.powf(e) - 1.0).abs() <= 1e-12 && e.abs() > 3.0 {
            format!("1e{e}")
        } else {
            crate::text::g(self.scale)
        };
        if (self.scale - 1.0).abs() <= 1e-12 {
            write!(f, "{d}")
        } else if d == "1" {
            write!(f, "{scale}")
        } else {
            write!(f, "{scale}·{d}")
        }
    }
}

/// Why a unit string does not parse: what, where (a character offset into the string), and
/// a suggestion.
#[derive(Clone, Debug, PartialEq)]
pub struct UnitError {
    /// The problem.
    pub message: String,
    /// Character offset of the problem in the unit string.
    pub at: usize,
    /// What to write instead, if there is a likely fix.
    pub suggestion: Option<String>,
}

/// Parses a unit string (see the module docs for the grammar).
pub fn parse(text: &str) -> Result<Unit, UnitError> {
    let chars: Vec<char> = text.chars().collect();
    let mut p = Parser { s: &chars, i: 0 };
    p.skip_ws();
    if p.i == chars.len() {
        return Ok(Unit::ONE);
    }
    let u = p.unit()?;
    p.skip_ws();
    if p.i < chars.len() {
        return Err(p.err(format!("unexpected `{}`", chars[p.i]), None));
    }
    Ok(u)
}

struct Parser<'a> {
    s: &'a [char],
    i: usize,
}

impl Parser<'_> {
    fn peek(&self) -> Option<char> {
        self.s.get(self.i).copied()
    }

    fn skip_ws(&mut self) {
        while self.peek().is_some_and(char::is_whitespace) {
            self.i += 1;
        }
    }

    fn err(&self, message: String, suggestion: Option<String>) -> UnitError {
        UnitError {
            message,
            at: self.i,
            suggestion,
        }
    }

    fn unit(&mut self) -> Result<Unit, UnitError> {
        let mut u = self.term()?;
        loop {
            self.skip_ws();
            match self.peek() {
                Some('*' | '·' | '×') => {
                    self.i += 1;
                    u = u * self.term()?;
                }
                Some('/') => {
                    self.i += 1;
                    u = u / self.term()?;
                }
                _ => return Ok(u),
            }
        }
    }

    fn term(&mut self) -> Result<Unit, UnitError> {
        let f = self.factor()?;
        self.skip_ws();
        match self.peek() {
            Some('^') => {
                self.i += 1;
                self.skip_ws();
                let start = self.i;
                if self.peek() == Some('-') {
                    self.i += 1;
                }
                while self.peek().is_some_and(|c| c.is_ascii_digit()) {
                    self.i += 1;
                }
                let digits: String = self.s[start..self.i].iter().collect();
                match digits.parse::<i8>() {
                    Ok(n) if (-9..=9).contains(&n) => Ok(f.powi(n)),
                    _ => {
                        self.i = start;
                        Err(self.err(
                            "expected a small integer exponent after `^`".into(),
                            Some("write `m^2` or `s^-1`".into()),
                        ))
                    }
                }
            }
            Some('²') => {
                self.i += 1;
                Ok(f.powi(2))
            }
            Some('³') => {
                self.i += 1;
                Ok(f.powi(3))
            }
            _ => Ok(f),
        }
    }

    fn factor(&mut self) -> Result<Unit, UnitError> {
        self.skip_ws();
        match self.peek() {
            Some('(') => {
                self.i += 1;
                let u = self.unit()?;
                self.skip_ws();
                if self.peek() != Some(')') {
                    return Err(self.err("expected `)`".into(), None));
                }
                self.i += 1;
                Ok(u)
            }
            Some('1') => {
                self.i += 1;
                Ok(Unit::ONE)
            }
            Some(c) if is_symbol_char(c) => {
                let start = self.i;
                while self.peek().is_some_and(is_symbol_char) {
                    self.i += 1;
                }
                let sym: String = self.s[start..self.i].iter().collect();
                symbol(&sym).ok_or_else(|| UnitError {
                    message: format!("unknown unit `{sym}`"),
                    at: start,
                    suggestion: suggest(&sym),
                })
            }
            Some(c) => Err(self.err(format!("unexpected `{c}`"), None)),
            None => Err(self.err("the unit ends too early".into(), None)),
        }
    }
}

fn is_symbol_char(c: char) -> bool {
    c.is_alphabetic() || c == '%' || c == 'µ' || c == 'Ω'
}

/// One symbol: a base unit, or an SI prefix and a base that takes prefixes.
fn symbol(sym: &str) -> Option<Unit> {
    let unit = |&(_, scale, dims, _): &Base| Unit { scale, dims };
    if let Some(b) = BASES.iter().find(|b| b.0 == sym) {
        return Some(unit(b));
    }
    if sym.contains('Ω') {
        return symbol(&sym.replace('Ω', "Ohm"));
    }
    PREFIXES.iter().find_map(|(p, f)| {
        let rest = sym.strip_prefix(p)?;
        let b = BASES.iter().find(|b| b.0 == rest && b.3)?;
        let u = unit(b);
        Some(Unit {
            scale: u.scale * f,
            ..u
        })
    })
}

/// Spellings users write for a unit qloop spells differently.
const ALIASES: &[(&str, &str)] = &[
    ("sec", "s"),
    ("secs", "s"),
    ("second", "s"),
    ("seconds", "s"),
    ("mins", "min"),
    ("minute", "min"),
    ("hr", "h"),
    ("RPM", "rpm"),
    ("rev/min", "rpm"),
    ("revs", "rev"),
    ("percent", "%"),
    ("pct", "%"),
    ("Nm", "N*m"),
    ("kNm", "kN*m"),
    ("mmpm", "mm/min"),
    ("ipm", "in/min"),
    ("inch", "in"),
    ("inches", "in"),
    ("degree", "deg"),
    ("degrees", "deg"),
    ("volt", "V"),
    ("volts", "V"),
];

/// A likely intended unit for an unknown symbol: a known alias, a case variant, or the
/// nearest known symbol (with prefixes) by edit distance.
fn suggest(sym: &str) -> Option<String> {
    if let Some((_, to)) = ALIASES.iter().find(|(a, _)| *a == sym) {
        return Some((*to).to_string());
    }
    let mut known: Vec<String> = Vec::new();
    for b in BASES {
        known.push(b.0.to_string());
        if b.3 {
            for (p, _) in PREFIXES.iter().filter(|(p, _)| *p != "μ") {
                known.push(format!("{p}{}", b.0));
            }
        }
    }
    if let Some(k) = known.iter().find(|k| k.eq_ignore_ascii_case(sym)) {
        return Some(k.clone());
    }
    let (best, d) = known
        .iter()
        .map(|k| (k, edit_distance(sym, k)))
        .min_by_key(|(_, d)| *d)?;
    (d <= 1 || (d == 2 && sym.chars().count() > 3)).then(|| best.clone())
}

/// Levenshtein distance over chars.
fn edit_distance(a: &str, b: &str) -> usize {
    let (a, b): (Vec<char>, Vec<char>) = (a.chars().collect(), b.chars().collect());
    let mut prev: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.iter().enumerate() {
        let mut cur = vec![i + 1];
        for (j, cb) in b.iter().enumerate() {
            let sub = prev[j] + usize::from(ca != cb);
            cur.push(sub.min(prev[j + 1] + 1).min(cur[j] + 1));
        }
        prev = cur;
    }
    prev[b.len()]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn u(s: &str) -> Unit {
        parse(s).unwrap_or_else(|e| panic!("{s}: {e:?}"))
    }

    #[test]
    fn machining_units_have_their_si_values() {
        // Independent truth: the SI definitions of each unit.
        let kn = u("kN");
        assert_eq!(kn.dims, [1, 1, -2, 0, 0, 0, 0, 0]);
        assert_eq!(kn.scale, 1e3);
        assert!(u("mm/s").same(&Unit {
            scale: 1e-3,
            dims: [0, 1, -1, 0, 0, 0, 0, 0]
        }));
        assert!(u("mm/min").same(&Unit {
            scale: 1e-3 / 60.0,
            dims: [0, 1, -1, 0, 0, 0, 0, 0]
        }));
        assert!(u("rpm").same(&u("rev/min")));
        assert!(u("kW").same(&u("kN*m/s")));
        assert!(u("kW").same(&u("kJ/s")));
        assert!(u("(mm/s)/kN").same(&u("mm/(s·kN)")));
        assert!(u("kN/(mm/s)").same(&u("(mm/s)/kN").powi(-1)));
        assert!(u("1/s").same(&u("Hz")));
        assert!(u("s^-1").same(&u("Hz")));
        assert!(u("m²").same(&u("m^2")));
        assert!(u("%").same(&Unit {
            scale: 0.01,
            dims: [0; BASE_DIMS]
        }));
        assert!(u("").same(&Unit::ONE) && u("1").same(&Unit::ONE));
        assert!(u("ms").same(&Unit {
            scale: 1e-3,
            ..Unit::SECOND
        }));
        assert!(u("µm").same(&u("um")));
        assert!((u("in/min").factor_to(&u("mm/s")).unwrap() - 25.4 / 60.0).abs() < 1e-15);
        assert!(
            ((u("mm/rev") * u("rpm")).factor_to(&u("mm/s")).unwrap() - 1.0 / 60.0).abs() < 1e-15
        );
        assert!(
            (u("rad").factor_to(&u("deg")).unwrap() - 180.0 / std::f64::consts::PI).abs() < 1e-12
        );
        assert_eq!(u("N").factor_to(&u("kN")), Some(1e-3));
        assert_eq!(u("N").factor_to(&u("mm")), None);
        assert!(!u("mm/rev").same_dimension(&u("mm/s")));
        assert_eq!(u("kN").dimension_name(), Some("force"));
    }

    #[test]
    fn unknown_text_is_located_with_a_suggestion() {
        let e = parse("mm/sec").unwrap_err();
        assert_eq!((e.at, e.suggestion.as_deref()), (3, Some("s")));
        let e = parse("kn").unwrap_err();
        assert_eq!(e.suggestion.as_deref(), Some("kN"));
        let e = parse("RPM").unwrap_err();
        assert_eq!(e.suggestion.as_deref(), Some("rpm"));
        let e = parse("kN/(mm/s").unwrap_err();
        assert_eq!(e.at, 8);
        let e = parse("m^x").unwrap_err();
        assert_eq!(e.at, 2);
        assert!(parse("furlong").unwrap_err().suggestion.is_none());
        assert!(parse("K²").is_ok() && parse("kK").is_err());
        assert!(u("kΩ").same(&u("kOhm")) && u("Ω").same(&u("V/A")));
    }
}
