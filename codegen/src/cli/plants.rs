//! `qloop plants`: the plant contracts ([`qloop_plant::Contract`]) and built-in scenarios.

use super::error::{CliError, CliResult};
use qloop_plant::{catalog, Contract};

/// Prints the contract of `plant` (or of every built-in plant) and its scenarios.
pub fn run(plant: Option<&str>) -> CliResult {
    let names: Vec<&str> = match plant {
        Some(p) => vec![p],
        None => catalog::PLANTS.to_vec(),
    };
    for (i, name) in names.iter().enumerate() {
        let p = catalog::plant_named(name).map_err(CliError::input)?;
        if i > 0 {
            println!();
        }
        print!("{}", Contract::of(p.as_ref()).describe());
        let scs: Vec<String> = catalog::scenarios_of(name)
            .iter()
            .map(|s| format!("{} ({} s)", s.name, s.duration_s))
            .collect();
        println!("  scenarios: {} (or a scenario TOML file)", scs.join(", "));
        let faults: Vec<String> = catalog::fault_scenarios_of(name)
            .iter()
            .map(|s| format!("{} ({} s)", s.name, s.duration_s))
            .collect();
        if !faults.is_empty() {
            println!(
                "  fault scenarios (sensor and process faults; not in a sweep's default set): {}",
                faults.join(", ")
            );
        }
    }
    Ok(())
}
