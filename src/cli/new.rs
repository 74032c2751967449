//! `revelio new PATH`: scaffold a domain to port from — `PATH.rev` (concepts, modifier,
//! constraint, question, rules), `PATH/world.rev` (world, kinds, region, presets),
//! `PATH/look.rev` (camera, scenery, looks) and `PATH/sim.toml` (a sim profile with one planted
//! failure mode). The scaffold checks clean, the render lint included, renders a contact sheet
//! and searches to a report as it stands, so a port starts from something that works and
//! changes one thing at a time (docs/porting.md). Nothing is overwritten.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

#[derive(clap::Args, Debug)]
pub struct NewArgs {
    /// The domain file to create (`yard` or `yard.rev`); its name is the domain's name and its
    /// modules go in a folder of that name beside it
    #[arg(value_name = "PATH")]
    pub path: PathBuf,
}

/// The scaffold's files: the path below the domain's folder (`None`: the domain file itself)
/// and the text, in which `$name` stands for the domain's name.
const FILES: &[(Option<&str>, &str)] = &[
    (None, include_str!("new/domain.rev")),
    (Some("world.rev"), include_str!("new/world.rev")),
    (Some("look.rev"), include_str!("new/look.rev")),
    (Some("sim.toml"), include_str!("new/sim.toml")),
];

/// Words the grammar reserves: not names.
const RESERVED: &[&str] = &["and", "or", "not", "true", "false", "has", "exists", "count", "where", "in"];

/// Why `name` cannot name a domain, if it cannot.
fn bad_name(name: &str) -> Option<String> {
    let ok_start = name.chars().next().is_some_and(|c| c.is_ascii_alphabetic() || c == '_');
    if !ok_start || !name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
        return Some(format!("`{name}` is not a domain name: use letters, digits and `_`, starting with a letter"));
    }
    RESERVED.contains(&name).then(|| format!("`{name}` is a reserved word of the language, not a domain name"))
}

/// The files the scaffold writes for `path`, with their text; `Err` says why the path cannot
/// hold a domain.
pub fn scaffold(path: &Path) -> Result<Vec<(PathBuf, String)>, String> {
    let stem_path =
        if path.extension().is_some_and(|x| x == "rev") { path.with_extension("") } else { path.to_path_buf() };
    let Some(name) = stem_path.file_name().and_then(|n| n.to_str()) else {
        return Err(format!("`{}` names no file", path.display()));
    };
    if let Some(why) = bad_name(name) {
        return Err(why);
    }
    let domain_file = stem_path.with_extension("rev");
    Ok(FILES
        .iter()
        .map(|(sub, text)| {
            let file = match sub {
                None => domain_file.clone(),
                Some(sub) => stem_path.join(sub),
            };
            (file, text.replace("$name", name))
        })
        .collect())
}

pub fn run(args: NewArgs) -> ExitCode {
    let files = match scaffold(&args.path) {
        Ok(f) => f,
        Err(why) => {
            eprintln!("error: {why}");
            return ExitCode::from(2);
        }
    };
    if let Some((f, _)) = files.iter().find(|(f, _)| f.exists()) {
        eprintln!("error: `{}` already exists; `revelio new` overwrites nothing (choose another PATH)", f.display());
        return ExitCode::from(1);
    }
    for (f, text) in &files {
        let dir = f.parent().filter(|d| !d.as_os_str().is_empty());
        if let Some(dir) = dir
            && let Err(e) = std::fs::create_dir_all(dir)
        {
            eprintln!("error: cannot create folder `{}`: {e}", dir.display());
            return ExitCode::from(1);
        }
        if let Err(e) = std::fs::write(f, text) {
            eprintln!("error: cannot write `{}`: {e}", f.display());
            return ExitCode::from(1);
        }
        println!("wrote {}", f.display());
    }
    let domain = files[0].0.display();
    let sim = files[3].0.display();
    let name = files[0].0.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    println!();
    println!("next:");
    println!("  revelio check {domain} --render 2");
    println!("  revelio render {domain} --all -o contact.png");
    println!("  revelio search {domain} --model sim:{sim} --out runs/{name}");
    println!("then make it yours, one change at a time: docs/porting.md");
    ExitCode::SUCCESS
}
