//! The catalogue: every method the registry knows, one card each ([`Card`]), and the sweeps
//! they are measured at. This file is the only one that names every method: each built-in
//! method is one adapter module here (its card, its typed setting, its per-cloud state) and one
//! line of [`BUILT_IN`]; methods in other languages come from `method.toml` folders
//! ([`external`]); a program embedding the registry, or a test, adds its own card at run time
//! ([`register`]). Visibility and level-of-detail methods share one namespace (a sweeps file
//! names both).
//!
//! The sweeps (`sweeps.toml`, data) give each built-in method's grids; its default setting is
//! its card's ([`Card::default_setting`]) unless a sweeps file names one.

mod exact;
pub mod external;
mod hpr;
mod hpr_approx;
mod hpr_confidence;
mod neuralvis;
pub(crate) mod qsplat;
mod random;
mod raycast;
mod reference;
mod robust;
mod screenspace;
mod splat;
pub(crate) mod spt;
mod srn;
#[cfg(test)]
mod tests;
mod vardensity;

use crate::card::Card;
use crate::error::{Error, Result};
use crate::sweep::{BUILTIN, Sweeps};

/// The built-in methods, in listing order: visibility, then level of detail.
pub static BUILT_IN: &[&Card] = &[
    &reference::CARD,
    &exact::CARD,
    &hpr::CARD,
    &hpr_confidence::CARD,
    &hpr_approx::CARD,
    &robust::CARD,
    &raycast::CARD,
    &splat::CARD,
    &screenspace::CARD,
    &vardensity::CARD,
    &neuralvis::CARD,
    &qsplat::CARD,
    &spt::CARD,
    &srn::CARD,
    &random::CARD,
];

/// The methods one run knows: the built-in ones ([`BUILT_IN`]), then those it added (external
/// programs' folders, a program's or a test's own cards), in the order added. A value, not
/// process state: each run, test or Python session builds its own, side by side.
#[derive(Clone, Default)]
pub struct Catalogue {
    added: Vec<&'static Card>,
}

/// Ends a catalogue's warm programs when dropped ([`Catalogue::end_programs_on_drop`]).
pub struct EndPrograms(Catalogue);

impl Drop for EndPrograms {
    fn drop(&mut self) {
        self.0.end_programs();
    }
}

impl std::fmt::Debug for Catalogue {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_list()
            .entries(self.cards().iter().map(|c| c.name))
            .finish()
    }
}

impl Catalogue {
    /// The built-in methods alone.
    pub fn builtin() -> Self {
        Self::default()
    }

    /// Adds `card` (a program embedding the registry, or a test, plugs its own method in
    /// here: one card, one call). Its name must be new among visibility and LOD methods alike.
    pub fn add(&mut self, card: &'static Card) -> Result<()> {
        if self.card_named(card.name).is_some() {
            return Err(Error::Unsupported(format!(
                "a method named {} is already registered",
                card.name
            )));
        }
        self.added.push(card);
        Ok(())
    }

    /// Ends the programs its external methods keep running between preparations (protocol
    /// 3's warm program, one per method and cloud), once no preparation holds them: what a
    /// run, a test or a Python call does when it is done with its methods. A later
    /// preparation starts a fresh one.
    pub fn end_programs(&self) {
        for card in &self.added {
            if let crate::card::Kind::Visibility(method) = card.kind {
                method.end();
            }
        }
    }

    /// A guard that ends its warm programs ([`Catalogue::end_programs`]) when dropped: at the
    /// end of a command or a call, whether it succeeded or not.
    pub fn end_programs_on_drop(&self) -> EndPrograms {
        EndPrograms(self.clone())
    }

    /// Every method: built-in, then the added ones.
    pub fn cards(&self) -> Vec<&'static Card> {
        BUILT_IN
            .iter()
            .copied()
            .chain(self.added.iter().copied())
            .collect()
    }

    /// The visibility methods, in listing order.
    pub fn visibility_cards(&self) -> Vec<&'static Card> {
        self.cards().into_iter().filter(|c| !c.is_lod()).collect()
    }

    /// The level-of-detail methods, in listing order.
    pub fn lod_cards(&self) -> Vec<&'static Card> {
        self.cards().into_iter().filter(|c| c.is_lod()).collect()
    }

    /// The method called `name`, if any.
    pub fn card_named(&self, name: &str) -> Option<&'static Card> {
        BUILT_IN
            .iter()
            .chain(&self.added)
            .copied()
            .find(|c| c.name == name)
    }

    /// The method called `name`, or an error listing the known ones.
    pub fn card(&self, name: &str) -> Result<&'static Card> {
        self.card_named(name).ok_or_else(|| Error::UnknownMethod {
            name: name.to_owned(),
            known: self
                .cards()
                .iter()
                .map(|c| c.name)
                .collect::<Vec<_>>()
                .join(", "),
        })
    }

    /// Every method with a sweep: the built-in grids, the external methods' and added cards'
    /// own, then `user` over them (each of our methods' default setting its card's unless a
    /// file names one). A method `user` names that is not in the catalogue is an error.
    pub fn sweeps(&self, user: Option<Sweeps>) -> Result<Sweeps> {
        let mut base = Sweeps::parse(BUILTIN, "registry/src/sweeps.toml")?;
        for c in self.cards() {
            if let Some(s) = &c.sweep {
                base.methods.insert(c.name.to_owned(), s.clone());
            }
        }
        if let Some(user) = &user {
            for name in user.methods.keys() {
                self.card(name)?;
            }
        }
        Ok(with_card_defaults(
            match user {
                Some(u) => base.overlay(u),
                None => base,
            },
            self,
        ))
    }
}

/// The built-in method called `name`, if any.
pub fn builtin_card(name: &str) -> Option<&'static Card> {
    BUILT_IN.iter().copied().find(|c| c.name == name)
}

/// Gives every sweep of one of our methods (not an external program's, whose manifest says)
/// that names no default setting its card's.
fn with_card_defaults(mut sweeps: Sweeps, catalogue: &Catalogue) -> Sweeps {
    for (name, sweep) in &mut sweeps.methods {
        if sweep.default.is_none()
            && let Some(card) = catalogue.card_named(name).filter(|c| !c.is_external())
        {
            sweep.default = Some(card.default_setting());
        }
    }
    sweeps
}

impl Sweeps {
    /// The built-in grids (`sweeps.toml`), each method's default setting its card's.
    pub fn builtin() -> Self {
        // The file is part of this crate and tested; an error is a build defect.
        with_card_defaults(
            Self::parse(BUILTIN, "registry/src/sweeps.toml").unwrap_or_default(),
            &Catalogue::builtin(),
        )
    }
}
