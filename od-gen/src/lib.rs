//! od-gen: one drive profile file → the firmware's object dictionary, the SII EEPROM image and
//! the ESI XML.
//!
//! A mismatch between the dictionary compiled into the slave, the SII that the master reads at
//! start-up and the ESI that the configuration tool imports is the most common reason a slave
//! does not reach SAFE-OP. od-gen derives all three from one TOML file, and derives the
//! communication objects (1008h, 1009h, 100Ah, 1018h, 16xxh/1Axxh, 1C00h, 1C12h, 1C13h, 1C32h,
//! 1C33h) from the device, PDO, SM and sync sections, so they cannot disagree.
//!
//! # Modules
//!
//! | module | does |
//! |---|---|
//! | [`compose`] | a file's layers merged: `extends` base, `from` library objects, `omit`, `[[replicate]]` |
//! | `locate` | key path → the file and line that wrote it (error messages) |
//! | [`file`] | the TOML format (serde types; every key is documented there and in `README.md`) |
//! | [`resolve`] | file → checked [`Profile`] with the derived objects |
//! | `storage` | the `[storage]` section: parameter storage rules resolved and checked against the dictionary |
//! | `adjusting` | the `[[adjusting]]` section: adjusting-service objects checked against the dictionary |
//! | `validate` | profile-wide checks (SM layout, mailbox, sync, roles, motor-fault codes, EEPROM size) |
//! | [`model`] | the resolved profile |
//! | [`rust`] | the generated Rust (`OUT_DIR/profiles.rs` of the firmware) |
//! | [`sii`] | the SII EEPROM image |
//! | [`esi`] | the ESI XML |
//! | [`table`] | the object table (`od-gen table`: CSV or aligned text) |
//! | [`doc`] | the Markdown page of a profile (`od-gen doc`, `docs/profiles/`) |
//! | [`cli`] | the `od-gen` command line |
//!
//! # Example
//!
//! ```
//! let p = od_gen::builtin("standard").unwrap();
//! assert_eq!(p.sii_image().len(), p.eeprom.byte_size);
//! assert!(p.esi_xml().contains("<Fmmu>Outputs</Fmmu>"));
//! let code = od_gen::rust::generate(&[p]);
//! assert!(code.contains("pub mod standard"));
//! ```

mod adjusting;
pub mod cli;
pub mod compose;
pub mod doc;
pub mod error;
pub mod esi;
pub mod file;
mod locate;
pub mod model;
pub mod resolve;
pub mod rust;
pub mod sii;
mod storage;
pub mod table;
mod validate;

use std::path::Path;

pub use error::{Error, Invalid};
pub use model::Profile;

include!(concat!(env!("OUT_DIR"), "/builtin.rs"));

/// The generated outputs of a profile. They live here, not in [`model`], so that the model does
/// not depend on the generators ([`sii`] and [`esi`] depend on [`model`]).
impl Profile {
    /// The SII EEPROM image ([`sii::image`]).
    pub fn sii_image(&self) -> Vec<u8> {
        sii::image(self)
    }
    /// The ESI XML ([`esi::xml`]).
    pub fn esi_xml(&self) -> String {
        esi::xml(self)
    }
}

/// The names of the built-in profiles (`od-gen/profiles/*.toml`), sorted.
pub fn builtin_names() -> Vec<&'static str> {
    BUILTIN.iter().map(|(n, _)| *n).collect()
}

/// Whether two profile names are the same profile: `sigma-v-sd` and `sigma_v_sd` are (CLI
/// names use hyphens, Rust module names underscores).
pub fn same_name(a: &str, b: &str) -> bool {
    a.len() == b.len()
        && a.bytes()
            .zip(b.bytes())
            .all(|(x, y)| x == y || (matches!(x, b'-' | b'_') && matches!(y, b'-' | b'_')))
}

/// `<dir>/<name>.toml` if it exists, the name spelt as given, with `-` or with `_`.
pub fn profile_file(dir: &Path, name: &str) -> Option<std::path::PathBuf> {
    [
        name.to_string(),
        name.replace('_', "-"),
        name.replace('-', "_"),
    ]
    .iter()
    .map(|stem| dir.join(format!("{stem}.toml")))
    .find(|p| p.is_file())
}

/// The file stem and text of a built-in profile, by either spelling of its name.
pub(crate) fn builtin_text(name: &str) -> Option<(&'static str, &'static str)> {
    BUILTIN.iter().copied().find(|(n, _)| same_name(n, name))
}

/// Loads a built-in profile by name (`sdv3-e` or `sdv3_e`).
pub fn builtin(name: &str) -> Result<Profile, Error> {
    let (stem, text) = builtin_text(name).ok_or_else(|| Error::UnknownProfile {
        name: name.to_string(),
        available: builtin_names(),
    })?;
    let source = format!("builtin:{stem}");
    let p = resolve::parse(text, &source, None)?;
    check_stem(&p, stem, &source)?;
    Ok(p)
}

/// Loads every built-in profile.
pub fn builtin_profiles() -> Result<Vec<Profile>, Error> {
    builtin_names().into_iter().map(builtin).collect()
}

/// Parses profile text; `source` names it in error messages.
/// `extends` finds built-in bases only.
pub fn parse(text: &str, source: &str) -> Result<Profile, Error> {
    resolve::parse(text, source, None)
}

/// Loads a profile file.
pub fn load(path: &Path) -> Result<Profile, Error> {
    let text = std::fs::read_to_string(path).map_err(|source| Error::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let p = resolve::parse(&text, &path.display().to_string(), path.parent())?;
    if let Some(stem) = path.file_stem().and_then(|s| s.to_str()) {
        check_stem(&p, stem, &path.display().to_string())?;
    }
    Ok(p)
}

/// Loads every `*.toml` in a directory, sorted by file name.
pub fn load_dir(dir: &Path) -> Result<Vec<Profile>, Error> {
    let io = |source| Error::Io {
        path: dir.to_path_buf(),
        source,
    };
    let mut files: Vec<_> = std::fs::read_dir(dir)
        .map_err(io)?
        .collect::<Result<Vec<_>, _>>()
        .map_err(io)?
        .into_iter()
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .collect();
    files.sort_by_key(|p| p.file_stem().map(|s| s.to_os_string()));
    files.iter().map(|f| load(f)).collect()
}

/// A built-in name or a path to a `.toml` file.
pub fn load_any(name_or_path: &str) -> Result<Profile, Error> {
    let path = Path::new(name_or_path);
    if name_or_path.ends_with(".toml") || path.components().count() > 1 {
        load(path)
    } else {
        builtin(name_or_path)
    }
}

/// The profile `name` must equal the file stem, so that file, module and name agree.
fn check_stem(p: &Profile, stem: &str, source: &str) -> Result<(), Error> {
    if p.name == stem {
        Ok(())
    } else {
        Err(Error::Invalid {
            file: source.to_string(),
            key: "name".into(),
            line: None,
            error: Invalid::Value(format!("`{}` differs from the file name `{stem}`", p.name)),
        })
    }
}
