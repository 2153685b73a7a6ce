//! The catalogue commands: `methods` (every registered method, its parameters and whether it
//! can run here) and `sweeps` (the built-in sweeps file).

use anyhow::Result;

/// `pointsight methods`.
pub fn list_methods() -> Result<()> {
    let show = |m: &registry::Card, prefix: &str| {
        match m.availability() {
            Ok(()) => println!("{:<10} {}", m.name, m.summary),
            Err(why) => println!("{:<10} {} [{why}]", m.name, m.summary),
        }
        for p in m.params {
            println!(
                "    {prefix}{}=…  (default {}) {}",
                p.key, p.default, p.help
            );
        }
    };
    for m in registry::visibility_cards() {
        show(m, "--set ");
    }
    println!("level of detail (experiment lod; sweeps keys):");
    for m in registry::lod_cards() {
        show(m, "");
    }
    Ok(())
}

/// `pointsight sweeps`: the built-in sweeps file, the template of a `--config`.
pub fn sweeps() {
    print!("{}", registry::sweep::BUILTIN);
}
