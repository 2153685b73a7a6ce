//! The catalogue commands: `methods` (every registered method, its parameters and, with
//! `--check`, whether its program is installed here) and `sweeps` (the built-in sweeps file).
//!
//! The listing runs no program: an external method's `check` (a Python import of its library,
//! say) takes a second or more each, so the checks run only on demand (`methods --check`), all
//! at once; every command that runs a method checks it anyway before it starts.

use anyhow::Result;

/// `pointsight methods [--check]`.
pub fn list_methods(run: &crate::run::Run, check: bool) -> Result<()> {
    let cards: Vec<&registry::Card> = run
        .catalogue
        .visibility_cards()
        .into_iter()
        .chain(run.catalogue.lod_cards())
        .collect();
    // The checks, in parallel (one process each), only when asked for.
    let availability: Vec<Option<std::result::Result<(), String>>> = if check {
        std::thread::scope(|s| {
            let handles: Vec<_> = cards
                .iter()
                .map(|m| s.spawn(move || m.is_external().then(|| m.availability())))
                .collect();
            handles
                .into_iter()
                .map(|h| {
                    h.join()
                        .unwrap_or_else(|_| Some(Err("its check panicked".into())))
                })
                .collect()
        })
    } else {
        vec![None; cards.len()]
    };
    let show = |m: &registry::Card, available: &Option<std::result::Result<(), String>>| {
        let prefix = if m.is_lod() { "" } else { "--set " };
        match available {
            Some(Err(why)) => println!("{:<10} {} [{why}]", m.name, m.summary),
            _ => println!("{:<10} {}", m.name, m.summary),
        }
        for p in m.params {
            println!(
                "    {prefix}{}=…  (default {}) {}",
                p.key, p.default, p.help
            );
        }
    };
    let mut lod_heading = false;
    for (m, available) in cards.iter().zip(&availability) {
        if m.is_lod() && !lod_heading {
            println!("level of detail (experiment lod; sweeps keys):");
            lod_heading = true;
        }
        show(m, available);
    }
    if !check && cards.iter().any(|m| m.is_external()) {
        println!(
            "(external programs are not checked here: `pointsight methods --check` says which \
             are installed)"
        );
    }
    Ok(())
}

/// `pointsight sweeps`: the built-in sweeps file, the template of a `--config`.
pub fn sweeps() {
    print!("{}", registry::sweep::BUILTIN);
}
