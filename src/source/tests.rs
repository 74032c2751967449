//! Loading a domain's files from disk under the source policy: `use` inside the tree, refused
//! paths, links, special and binary files, and open editor buffers.
use std::path::Path;

use super::*;

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::create_dir_all(p.parent().unwrap()).unwrap();
    std::fs::write(&p, text).unwrap();
    p
}

fn codes_of(c: &Compiled) -> Vec<&'static str> {
    c.diagnostics.iter().map(|d| d.code).collect()
}

const SECRET: &str = "SECRET-CANARY-91c2";

/// No diagnostic of `c` quotes the secret, and no file holding it was kept.
fn never_quotes_secret(c: &Compiled) {
    for d in &c.diagnostics {
        let all = format!("{} {} {:?}", d.message, d.label, d.help);
        assert!(!all.contains(SECRET), "{all}");
    }
    assert!(c.files.iter().all(|f| !f.text.contains(SECRET)), "a refused file was loaded");
}

#[test]
fn uses_inside_the_tree_load_and_two_spellings_load_once() {
    let dir = tempfile::tempdir().unwrap();
    let main =
        write(dir.path(), "d/main.rev", "use \"lib/a.rev\"\nuse \"./lib/../lib/a.rev\"\nuse \"link.rev\"\ntag M");
    write(dir.path(), "d/lib/a.rev", "use \"../main.rev\"\nuse \"b.rev\"\ntag A");
    write(dir.path(), "d/lib/b.rev", "use \"../lib/a.rev\"\ntag B");
    #[cfg(unix)]
    std::os::unix::fs::symlink(dir.path().join("d/lib/a.rev"), dir.path().join("d/link.rev")).unwrap();
    #[cfg(not(unix))]
    write(dir.path(), "d/link.rev", "");
    // The entry spelled with a `.` segment: `lib/a.rev` using it back is the same file.
    let c = compile_file(&dir.path().join("d/./main.rev"));
    assert!(c.diagnostics.is_empty(), "{:?}", c.diagnostics);
    assert_eq!(c.files.len(), 4, "main, core, a and b: {:?}", c.files.iter().map(|f| &f.name).collect::<Vec<_>>());
    assert!(compile_file(&main).diagnostics.is_empty());
}

#[test]
fn paths_out_of_the_tree_or_of_other_kinds_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "secret.txt", SECRET);
    write(dir.path(), "secret.rev", &format!("tag {SECRET}"));
    write(dir.path(), "d/notes.txt", SECRET);
    let cases = [
        ("/proc/self/environ", "is an absolute path"),
        ("/etc/passwd.rev", "is an absolute path"),
        ("C:/x.rev", "is an absolute path"),
        // As written in `.rev` text, where a backslash is escaped.
        ("..\\\\secret.rev", "contains `\\`"),
        ("sub\\\\x.rev", "contains `\\`"),
        ("../secret.rev", "is outside the domain's folder"),
        ("sub/../../secret.rev", "is outside the domain's folder"),
        ("notes.txt", "is not a `.rev` file"),
        ("../secret.txt", "is not a `.rev` file"),
    ];
    for (path, says) in cases {
        let main = write(dir.path(), "d/main.rev", &format!("use \"{path}\"\ntag M"));
        let c = compile_file(&main);
        assert_eq!(codes_of(&c), [codes::USE_REFUSED], "{path}: {:?}", c.diagnostics);
        assert!(c.diagnostics[0].message.contains(says), "{path}: {}", c.diagnostics[0].message);
        never_quotes_secret(&c);
    }
}

#[cfg(unix)]
#[test]
fn links_are_judged_where_they_land() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "secret.rev", &format!("tag {SECRET}"));
    write(dir.path(), "d/notes.txt", SECRET);
    std::os::unix::fs::symlink(dir.path().join("secret.rev"), dir.path().join("d/out.rev")).unwrap();
    std::os::unix::fs::symlink(dir.path().join("d/notes.txt"), dir.path().join("d/notes.rev")).unwrap();
    std::os::unix::fs::symlink("/proc/self/environ", dir.path().join("d/env.rev")).unwrap();
    for (path, says) in [
        ("out.rev", "is outside the domain's folder"),
        ("env.rev", "is outside the domain's folder"),
        ("notes.rev", "is a link to a file that is not a `.rev` file"),
    ] {
        let main = write(dir.path(), "d/main.rev", &format!("use \"{path}\"\ntag M"));
        let c = compile_file(&main);
        assert_eq!(codes_of(&c), [codes::USE_REFUSED], "{path}: {:?}", c.diagnostics);
        assert!(c.diagnostics[0].message.contains(says), "{path}: {}", c.diagnostics[0].message);
        never_quotes_secret(&c);
    }
    // An entry that is a link to a file that is not a `.rev` file is not read either.
    let c = compile_file(&dir.path().join("d/notes.rev"));
    assert_eq!(codes_of(&c), [codes::USE_REFUSED]);
    never_quotes_secret(&c);
}

#[cfg(unix)]
#[test]
fn fifos_and_devices_are_refused_before_opening() {
    let dir = tempfile::tempdir().unwrap();
    let fifo = dir.path().join("d/pipe.rev");
    std::fs::create_dir_all(fifo.parent().unwrap()).unwrap();
    let made = std::process::Command::new("mkfifo").arg(&fifo).status();
    if !made.is_ok_and(|s| s.success()) {
        eprintln!("note: `mkfifo` is not available; the FIFO case is not checked");
        return;
    }
    // Opening the FIFO would block this test forever: reaching the assertions is the check.
    let main = write(dir.path(), "d/main.rev", "use \"pipe.rev\"\ntag M");
    let c = compile_file(&main);
    assert_eq!(codes_of(&c), [codes::USE_REFUSED]);
    assert!(c.diagnostics[0].message.contains("is a FIFO (named pipe)"), "{}", c.diagnostics[0].message);
    let c = compile_file(&fifo);
    assert!(c.diagnostics[0].message.contains("is a FIFO (named pipe)"), "{}", c.diagnostics[0].message);
    let zero = read(Path::new("/dev/zero"), "/dev/zero").unwrap_err();
    assert_eq!(zero.message, "`/dev/zero` is a character device, not a `.rev` file");
}

#[test]
fn large_and_binary_files_are_refused_without_quoting() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir_all(dir.path().join("d")).unwrap();
    // Sparse: two MiB long, none of it written.
    std::fs::File::create(dir.path().join("d/big.rev")).unwrap().set_len(2 << 20).unwrap();
    std::fs::write(dir.path().join("d/bin.rev"), [0xff, 0xfe, b'S', b'E', b'C']).unwrap();
    let main = write(dir.path(), "d/main.rev", "use \"big.rev\"\nuse \"bin.rev\"\ntag M");
    let c = compile_file(&main);
    assert_eq!(codes_of(&c), [codes::FILE_TOO_LARGE, codes::FILE_NOT_FOUND], "{:?}", c.diagnostics);
    assert!(c.diagnostics[0].message.ends_with("big.rev` is 2 MiB; a `.rev` file may be at most 1 MiB"));
    assert!(c.diagnostics[1].message.ends_with("bin.rev`: not UTF-8 text"));
    let c = compile_file(&dir.path().join("d/big.rev"));
    assert_eq!(codes_of(&c), [codes::FILE_TOO_LARGE]);
}

#[test]
fn entries_must_be_rev_files() {
    let dir = tempfile::tempdir().unwrap();
    let notes = write(dir.path(), "notes.txt", &format!("concept {SECRET}"));
    let c = compile_file(&notes);
    assert_eq!(codes_of(&c), [codes::USE_REFUSED]);
    never_quotes_secret(&c);
    let c = compile_file(&dir.path().join("missing.rev"));
    assert_eq!(codes_of(&c), [codes::FILE_NOT_FOUND]);
    assert!(c.diagnostics[0].message.ends_with("missing.rev`: no such file"), "{}", c.diagnostics[0].message);
}

#[test]
fn open_buffers_come_first_under_the_same_policy() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "d/lib.rev", "tag OnDisk");
    let lib = normalize(&dir.path().join("d/lib.rev"));
    let open = |p: &Path| (p == lib).then(|| "tag InBuffer".to_string());
    let main = dir.path().join("d/main.rev");
    let c = compile_text(&main, "use \"lib.rev\"\nuse \"../x.rev\"\ntag T: InBuffer", &open);
    assert_eq!(codes_of(&c), [codes::USE_REFUSED], "{:?}", c.diagnostics);
    assert!(c.files.iter().any(|f| f.text == "tag InBuffer"));
}
