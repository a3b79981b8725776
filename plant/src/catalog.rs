//! The built-in plants and their scenarios, by name (for the `qloop sim` and `qloop sweep`
//! command line), and scenarios read from TOML files.

use crate::finishing::{self, Finishing, FinishingParams};
use crate::grinding::{self, Grinding, GrindingParams};
use crate::milling::{self, Milling, MillingParams};
use crate::plant::Plant;
use crate::scenario::Scenario;
use crate::turning::{self, Turning, TurningParams};

/// The names of the built-in plants.
pub const PLANTS: &[&str] = &["turning", "milling", "grinding", "finishing"];

/// The plant named `name`, with its default (paper) parameters.
pub fn plant_named(name: &str) -> Result<Box<dyn Plant>, String> {
    match name {
        "turning" => Ok(Box::new(Turning::new(TurningParams::default()))),
        "milling" => Ok(Box::new(Milling::new(MillingParams::default()))),
        "grinding" => Ok(Box::new(Grinding::new(GrindingParams::default()))),
        "finishing" => Ok(Box::new(Finishing::new(FinishingParams::default()))),
        _ => Err(format!(
            "unknown plant `{name}`; built-in plants: {}",
            PLANTS.join(", ")
        )),
    }
}

/// The built-in scenarios of the plant named `plant`.
pub fn scenarios_of(plant: &str) -> Vec<Scenario> {
    match plant {
        "turning" => turning::scenarios(),
        "milling" => milling::scenarios(),
        "grinding" => grinding::scenarios(),
        "finishing" => finishing::scenarios(),
        _ => Vec::new(),
    }
}

/// The fault scenarios of the plant named `plant` ([`crate::fault`]): named like the others,
/// but not among [`scenarios_of`], so that a sweep over "every scenario" measures the healthy
/// loop.
pub fn fault_scenarios_of(plant: &str) -> Vec<Scenario> {
    match plant {
        "turning" => turning::fault_scenarios(),
        _ => Vec::new(),
    }
}

/// The scenario `what` of `plant`: a built-in scenario name (healthy or faulty), or the path
/// of a TOML scenario file (see [`crate::scenario`]).
pub fn scenario(plant: &str, what: &str) -> Result<Scenario, String> {
    let mut builtin = scenarios_of(plant);
    builtin.extend(fault_scenarios_of(plant));
    if let Some(s) = builtin.iter().find(|s| s.name == what) {
        return Ok(s.clone());
    }
    let path = std::path::Path::new(what);
    if path.extension().is_some_and(|e| e == "toml") || path.exists() {
        let text = std::fs::read_to_string(path)
            .map_err(|e| format!("cannot read scenario file `{what}`: {e}"))?;
        return Scenario::from_toml(&text).map_err(|e| format!("{what}: {e}"));
    }
    let names: Vec<&str> = builtin.iter().map(|s| s.name.as_str()).collect();
    Err(format!(
        "unknown scenario `{what}` for the {plant} plant; built-in: {} (or give a .toml scenario file)",
        names.join(", ")
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_plant_has_scenarios_that_validate() {
        for p in PLANTS {
            let plant = plant_named(p).unwrap();
            assert_eq!(plant.name(), *p);
            let scs = scenarios_of(p);
            assert!(!scs.is_empty(), "{p}");
            for s in scs.into_iter().chain(fault_scenarios_of(p)) {
                s.validate().unwrap();
                assert_eq!(scenario(p, &s.name).unwrap(), s);
            }
        }
    }

    #[test]
    fn unknown_names_list_the_known_ones() {
        let e = plant_named("lathe").err().unwrap();
        assert!(e.contains("turning"), "{e}");
        let e = scenario("turning", "nope").unwrap_err();
        assert!(e.contains("depth-steps"), "{e}");
    }
}
