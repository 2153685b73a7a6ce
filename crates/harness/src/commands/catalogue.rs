//! The catalogue commands: `methods` (every registered method, its parameters and whether it
//! can run here) and `sweeps` (the built-in sweeps file).

use anyhow::Result;

/// `pointsight methods`.
pub fn list_methods() -> Result<()> {
    for m in registry::all() {
        match m.availability() {
            Ok(()) => println!("{:<10} {}", m.name(), m.summary()),
            Err(why) => println!("{:<10} {} [{why}]", m.name(), m.summary()),
        }
        for p in m.params() {
            println!("    --set {}=…  (default {}) {}", p.key, p.default, p.help);
        }
    }
    println!("level of detail (experiment lod; sweeps keys):");
    for m in registry::lod::all() {
        match m.availability() {
            Ok(()) => println!("{:<10} {}", m.name(), m.summary()),
            Err(why) => println!("{:<10} {} [{why}]", m.name(), m.summary()),
        }
        for p in m.params() {
            println!("    {}=…  (default {}) {}", p.key, p.default, p.help);
        }
    }
    Ok(())
}

/// `pointsight sweeps`: the built-in sweeps file, the template of a `--config`.
pub fn sweeps() {
    print!("{}", registry::sweep::BUILTIN);
}
