//! `qloop c2d`: a continuous transfer function discretised under a β fractional-order hold
//! (Rubio & De la Sen, eqs. 4–5; `qloop_plant::froh`), printed as a difference
//! equation and as `const` lines for a spec.

use super::error::{CliError, CliResult};
use qloop_plant::froh::{froh, ContinuousTf, DiscreteTf, PAPER_BETAS};

/// Parses `--beta`: a comma-separated list, or `paper` for Rubio & De la Sen's seven gains.
fn betas(text: &str) -> Result<Vec<f64>, CliError> {
    if text.trim() == "paper" {
        return Ok(PAPER_BETAS.to_vec());
    }
    text.split(',')
        .map(|b| {
            b.trim().parse::<f64>().map_err(|_| CliError::Input {
                msg: format!("--beta: `{}` is not a number", b.trim()),
                help: Some("give numbers in [-1, 1] separated by commas, or `paper`".into()),
            })
        })
        .collect()
}

/// `s^2 + 20 s + 550` style text of a polynomial, highest power first.
fn poly(c: &[f64], var: &str) -> String {
    let n = c.len().saturating_sub(1);
    let terms: Vec<String> = c
        .iter()
        .enumerate()
        .filter(|(_, &x)| x != 0.0)
        .map(|(i, &x)| {
            let c = if x == 1.0 && i < n {
                String::new()
            } else {
                format!("{x} ")
            };
            match n - i {
                0 => format!("{x}"),
                1 => format!("{c}{var}"),
                p => format!("{c}{var}^{p}"),
            }
        })
        .collect();
    if terms.is_empty() {
        "0".into()
    } else {
        terms.join(" + ").replace("+ -", "- ")
    }
}

/// The difference equation and `const` lines of one discrete model.
fn show(h: &DiscreteTf, beta: f64, name: &str) -> String {
    let m = h.order();
    let mut out = format!(
        "β = {beta}: order {m}{}\n  H(z) = ({}) / ({})\n  y(k) =",
        if beta != 0.0 {
            " (the hold's pole at z = 0)"
        } else {
            " (ZOH)"
        },
        poly(&h.num, "z"),
        poly(&h.den, "z")
    );
    let mut terms = Vec::new();
    for i in (1..=m).filter(|&i| h.den[i] != 0.0) {
        terms.push(format!("{} y(k-{i})", -h.den[i]));
    }
    for (i, b) in h.num.iter().enumerate() {
        if *b != 0.0 {
            terms.push(match i {
                0 => format!("{b} u(k)"),
                _ => format!("{b} u(k-{i})"),
            });
        }
    }
    out.push_str(&format!(" {}\n", terms.join(" + ").replace("+ -", "- ")));
    out.push_str(&format!(
        "  // {name}: β = {beta}, T = {} s (qloop c2d, Rubio & De la Sen, eqs. 4-5):\n  // H(z) = ({name}_B0 + {name}_B1 z^-1 + ...) / (1 + {name}_A1 z^-1 + ...)\n",
        h.period
    ));
    for i in 1..=m {
        out.push_str(&format!("  const {name}_A{i}: {:?};\n", h.den[i]));
    }
    for (i, b) in h.num.iter().enumerate() {
        out.push_str(&format!("  const {name}_B{i}: {b:?};\n"));
    }
    out
}

/// Discretises `num/den` at `period` for every β of `beta` and prints each model.
pub fn run(num: &[f64], den: &[f64], period: f64, beta: &str, name: &str) -> CliResult {
    let valid = |c: char| c == '_' || c.is_ascii_alphanumeric();
    if name.is_empty() || !name.chars().all(valid) || name.starts_with(|c: char| c.is_ascii_digit())
    {
        return Err(CliError::Input {
            msg: format!("--name `{name}` is not a spec identifier"),
            help: Some("use letters, digits and `_`, not starting with a digit".into()),
        });
    }
    let g = ContinuousTf::new(num, den);
    let betas = betas(beta)?;
    let mut text = format!(
        "β-FROH equivalents of G(s) = ({}) / ({}) at T = {period} s\n\n",
        poly(num, "s"),
        poly(den, "s")
    );
    for (i, &b) in betas.iter().enumerate() {
        let h = froh(&g, period, b).map_err(|e| CliError::Input {
            msg: e.to_string(),
            help: None,
        })?;
        let tag = if betas.len() > 1 {
            format!("{name}{i}")
        } else {
            name.to_string()
        };
        text.push_str(&show(&h, b, &tag));
        text.push('\n');
    }
    print!("{text}");
    Ok(())
}
