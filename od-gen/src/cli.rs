//! The `od-gen` command line.
//!
//! ```text
//! od-gen list                                   built-in profile names
//! od-gen esi  <profile-name-or-path> [-o FILE]  ESI XML (stdout without -o)
//! od-gen sii  <profile-name-or-path> [-o FILE]  SII image: binary to FILE, or a hex dump
//!                                               (16 bytes per line) to stdout without -o
//! od-gen rust <profile-name-or-path>... [-o FILE]  the generated Rust (for inspection)
//! od-gen check <profile-name-or-path>...        load and validate only
//! od-gen table <profile-name-or-path> [--csv] [-o FILE]
//!                                               the object table: one row per subindex,
//!                                               aligned text, or CSV with --csv
//! od-gen doc  <profile-name-or-path> [-o FILE]  the Markdown page of the profile
//! od-gen doc  --all -o DIR                      every built-in profile's page + README.md
//! ```
//!
//! A name without `/` and without `.toml` is a built-in profile; anything else is a path.

use std::io::Write as _;
use std::path::PathBuf;

use crate::Error;

/// Usage text.
pub const USAGE: &str = "usage:
  od-gen list
  od-gen esi  <profile-name-or-path> [-o FILE]   ESI XML (stdout without -o)
  od-gen sii  <profile-name-or-path> [-o FILE]   SII image (binary to FILE; hex dump to stdout without -o)
  od-gen rust <profile-name-or-path>... [-o FILE] generated Rust object dictionary
  od-gen check <profile-name-or-path>...         validate only
  od-gen table <profile-name-or-path> [--csv] [-o FILE]
                                                 object table (aligned text; CSV with --csv)
  od-gen doc  <profile-name-or-path> [-o FILE]   Markdown page of the profile
  od-gen doc  --all -o DIR                       pages of all built-in profiles + README.md
A name without '/' and without '.toml' is a built-in profile (see `od-gen list`).";

/// A command-line failure: a message for stderr.
#[derive(Debug)]
pub enum CliError {
    /// Wrong arguments.
    Usage(String),
    /// Loading or writing failed.
    Od(Error),
}

impl std::fmt::Display for CliError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Usage(m) => write!(f, "{m}\n{USAGE}"),
            Self::Od(e) => write!(f, "{e}"),
        }
    }
}

impl From<Error> for CliError {
    fn from(e: Error) -> Self {
        Self::Od(e)
    }
}

fn write_out(path: Option<&PathBuf>, data: &[u8]) -> Result<(), CliError> {
    match path {
        Some(p) => std::fs::write(p, data).map_err(|source| {
            Error::Io {
                path: p.clone(),
                source,
            }
            .into()
        }),
        None => std::io::stdout().write_all(data).map_err(|source| {
            Error::Io {
                path: "<stdout>".into(),
                source,
            }
            .into()
        }),
    }
}

/// Writes `DIR/<name>.md` for every built-in profile and the index `DIR/README.md`
/// (`od-gen doc --all -o DIR`); creates `DIR` if needed.
fn write_all_pages(dir: &std::path::Path) -> Result<(), CliError> {
    let io = |path: PathBuf| move |source| CliError::Od(Error::Io { path, source });
    std::fs::create_dir_all(dir).map_err(io(dir.to_path_buf()))?;
    let profiles = crate::builtin_profiles()?;
    for p in &profiles {
        let path = dir.join(format!("{}.md", p.name));
        std::fs::write(&path, crate::doc::markdown(p)).map_err(io(path.clone()))?;
    }
    let path = dir.join("README.md");
    std::fs::write(&path, crate::doc::index(&profiles)).map_err(io(path.clone()))?;
    let names: Vec<&str> = profiles.iter().map(|p| p.name.as_str()).collect();
    write_out(
        None,
        format!(
            "wrote {} pages ({}) and README.md to {}\n",
            names.len(),
            names.join(", "),
            dir.display()
        )
        .as_bytes(),
    )
}

/// Hex dump: `offset: 16 bytes` per line.
pub fn hex_dump(data: &[u8]) -> String {
    data.chunks(16)
        .enumerate()
        .map(|(i, c)| {
            let bytes: Vec<String> = c.iter().map(|b| format!("{b:02x}")).collect();
            format!("{:04x}: {}\n", i * 16, bytes.join(" "))
        })
        .collect()
}

/// Runs the command line (without the program name).
pub fn run(args: &[String]) -> Result<(), CliError> {
    let (cmd, rest) = args
        .split_first()
        .ok_or_else(|| CliError::Usage("missing command".into()))?;
    let mut inputs = Vec::new();
    let mut out: Option<PathBuf> = None;
    let (mut csv, mut all) = (false, false);
    let mut it = rest.iter();
    while let Some(a) = it.next() {
        match a.as_str() {
            "-o" | "--output" => {
                let p = it
                    .next()
                    .ok_or_else(|| CliError::Usage("-o needs a file name".into()))?;
                out = Some(PathBuf::from(p));
            }
            "--csv" if cmd == "table" => csv = true,
            "--all" if cmd == "doc" => all = true,
            s if s.starts_with('-') => {
                return Err(CliError::Usage(format!("unknown option `{s}` for `{cmd}`")))
            }
            s => inputs.push(s.to_string()),
        }
    }
    let one = |inputs: &[String]| -> Result<crate::Profile, CliError> {
        match inputs {
            [one] => Ok(crate::load_any(one)?),
            [] => Err(CliError::Usage(format!(
                "`{cmd}` needs a profile name or path"
            ))),
            _ => Err(CliError::Usage(format!("`{cmd}` takes one profile"))),
        }
    };
    match cmd.as_str() {
        "list" => {
            let mut s = String::new();
            for n in crate::builtin_names() {
                s.push_str(n);
                s.push('\n');
            }
            write_out(None, s.as_bytes())
        }
        "esi" => write_out(out.as_ref(), one(&inputs)?.esi_xml().as_bytes()),
        "table" => {
            let p = one(&inputs)?;
            let text = if csv {
                crate::table::csv(&p)
            } else {
                crate::table::text(&p)
            };
            write_out(out.as_ref(), text.as_bytes())
        }
        "doc" if all => {
            if !inputs.is_empty() {
                return Err(CliError::Usage(
                    "`doc --all` takes no profile (it writes every built-in one)".into(),
                ));
            }
            let dir = out.ok_or_else(|| {
                CliError::Usage("`doc --all` needs -o DIR (e.g. docs/profiles)".into())
            })?;
            write_all_pages(&dir)
        }
        "doc" => write_out(
            out.as_ref(),
            crate::doc::markdown(&one(&inputs)?).as_bytes(),
        ),
        "sii" => {
            let img = one(&inputs)?.sii_image();
            match out {
                Some(p) => write_out(Some(&p), &img),
                None => write_out(None, hex_dump(&img).as_bytes()),
            }
        }
        "rust" | "check" => {
            if inputs.is_empty() {
                return Err(CliError::Usage(format!(
                    "`{cmd}` needs at least one profile"
                )));
            }
            // Every profile is loaded, and the errors of all of them reported.
            let (mut profiles, mut errors) = (Vec::new(), Vec::new());
            for input in &inputs {
                match crate::load_any(input) {
                    Ok(p) => profiles.push(p),
                    Err(e) => errors.push(e),
                }
            }
            Error::all(errors)?;
            if cmd == "rust" {
                // Drive profiles generate for the firmware, device profiles for any other crate
                // on the slave stack; one file cannot hold both.
                use crate::model::ProfileKind;
                let devices = profiles.iter().filter(|p| p.kind == ProfileKind::Device);
                let target =
                    match (devices.count(), profiles.len()) {
                        (0, _) => crate::rust::Target::DRIVE_CRATE,
                        (d, n) if d == n => crate::rust::Target::DEVICE_CRATE,
                        _ => return Err(CliError::Usage(
                            "`rust` takes drive profiles or device profiles (kind = \"device\"), \
                             not both"
                                .into(),
                        )),
                    };
                write_out(
                    out.as_ref(),
                    crate::rust::generate_with(&profiles, &target).as_bytes(),
                )
            } else {
                let names: Vec<&str> = profiles.iter().map(|p| p.name.as_str()).collect();
                write_out(None, format!("ok: {}\n", names.join(", ")).as_bytes())
            }
        }
        "help" | "-h" | "--help" => write_out(None, format!("{USAGE}\n").as_bytes()),
        other => Err(CliError::Usage(format!("unknown command `{other}`"))),
    }
}
