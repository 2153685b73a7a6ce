//! Methods registered at run time, beside the built-in ones: one mechanism for both kinds
//! (visibility [`crate::Method`] and LOD [`crate::lod::LodMethod`]), and one namespace: a
//! sweeps file names methods of both kinds, so a name is taken once across them.

use std::sync::RwLock;

use crate::{Error, Result};

/// The methods of one kind registered at run time, in registration order.
pub(crate) struct Plugins<T: ?Sized + 'static>(RwLock<Vec<&'static T>>);

impl<T: ?Sized + Sync + 'static> Plugins<T> {
    /// None yet.
    pub(crate) const fn new() -> Self {
        Self(RwLock::new(Vec::new()))
    }

    /// Adds `method` called `name`, unless a visibility or LOD method has that name already.
    pub(crate) fn add(&self, name: &str, method: &'static T) -> Result<()> {
        if name_taken(name) {
            return Err(Error::Unsupported(format!(
                "a method named {name} is already registered"
            )));
        }
        self.0
            .write()
            .map_err(|_| Error::Unsupported("the method registry is poisoned".into()))?
            .push(method);
        Ok(())
    }

    /// `builtin`, then the registered methods.
    pub(crate) fn after(&self, builtin: &[&'static T]) -> Vec<&'static T> {
        let extra = self.0.read().map(|e| e.clone()).unwrap_or_default();
        builtin.iter().copied().chain(extra).collect()
    }
}

/// True when a visibility or LOD method (built-in or registered) is called `name`.
pub(crate) fn name_taken(name: &str) -> bool {
    crate::all().iter().any(|m| m.name() == name)
        || crate::lod::all().iter().any(|m| m.name() == name)
}

#[cfg(test)]
mod tests {
    use crate::lod::{LodBuilt, LodInput, LodMethod};
    use crate::{Input, Method, ParamSpec, Params, Prepared, Result};

    /// A visibility method that only has a name.
    struct Named(&'static str);
    impl Method for Named {
        fn name(&self) -> &'static str {
            self.0
        }
        fn summary(&self) -> &'static str {
            "test"
        }
        fn params(&self) -> &'static [ParamSpec] {
            &[]
        }
        fn prepare<'a>(&self, _: Input<'a>, _: &Params) -> Result<Box<dyn Prepared + 'a>> {
            Err(crate::Error::Unsupported("test".into()))
        }
    }

    /// An LOD method that only has a name.
    struct LodNamed(&'static str);
    impl LodMethod for LodNamed {
        fn name(&self) -> &'static str {
            self.0
        }
        fn summary(&self) -> &'static str {
            "test"
        }
        fn params(&self) -> &'static [ParamSpec] {
            &[]
        }
        fn build(&self, _: &LodInput<'_>) -> Result<Box<dyn LodBuilt>> {
            Err(crate::Error::Unsupported("test".into()))
        }
    }

    #[test]
    fn one_namespace_for_visibility_and_lod_methods() {
        // Built-in names of either kind are taken for both kinds.
        assert!(crate::register(&Named("srn")).is_err());
        assert!(crate::register(&Named("hpr")).is_err());
        assert!(crate::lod::register_lod(&LodNamed("hpr")).is_err());
        assert!(crate::lod::register_lod(&LodNamed("qsplat")).is_err());
        // A new name registers once, for its kind, and is then taken for the other kind too.
        crate::register(&Named("plugins-test-vis")).unwrap();
        assert!(crate::method("plugins-test-vis").is_ok());
        assert!(crate::register(&Named("plugins-test-vis")).is_err());
        assert!(crate::lod::register_lod(&LodNamed("plugins-test-vis")).is_err());
        crate::lod::register_lod(&LodNamed("plugins-test-lod")).unwrap();
        assert!(crate::lod::method("plugins-test-lod").is_some());
        assert!(crate::register(&Named("plugins-test-lod")).is_err());
    }

    #[test]
    fn an_external_method_may_not_take_a_built_in_lod_name() {
        let dir = std::env::temp_dir().join(format!("pointsight-plugins-{}", std::process::id()));
        let folder = dir.join("spt");
        std::fs::create_dir_all(&folder).unwrap();
        std::fs::write(
            folder.join("method.toml"),
            "protocol = 1\nsummary = \"test\"\ncommand = [\"true\"]\n",
        )
        .unwrap();
        let err = crate::register_external(&dir).unwrap_err().to_string();
        let _ = std::fs::remove_dir_all(&dir);
        assert!(err.contains("shadows a built-in method"), "{err}");
    }
}
