//! Files of a run folder are untrusted: run folders are copied between colleagues and
//! downloaded, so any name in one may be a symbolic link (to a file Revelio would then
//! overwrite), a FIFO (which blocks a reader forever), a device (`/dev/zero` reads without end)
//! or a file far larger than any run writes. Every file Revelio reads from or writes into a run
//! folder or a report folder goes through here: no link is followed (`O_NOFOLLOW`, and folders
//! Revelio creates are checked to be real folders), only regular files are read, and reads stop
//! at a bound.

use std::fs::{File, Metadata, OpenOptions};
use std::io::{self, Read, Write};
use std::path::Path;

/// The most a journal may hold (some hundreds of thousands of observations).
pub const MAX_JOURNAL_BYTES: u64 = 512 << 20;
/// The most a run folder's JSON file (`config.json`, `summary.json`, `probe.json`, …) may hold.
pub const MAX_JSON_BYTES: u64 = 64 << 20;
/// The most an image in a run folder may hold.
pub const MAX_IMAGE_BYTES: u64 = 64 << 20;
/// The most the lock file's note of its holder may hold.
pub const MAX_LOCK_BYTES: u64 = 4 << 10;

/// Open flags that keep the last component from being a link and a FIFO from blocking the open.
#[cfg(unix)]
fn guarded(opts: &mut OpenOptions) -> &mut OpenOptions {
    use std::os::unix::fs::OpenOptionsExt;
    opts.custom_flags(libc::O_NOFOLLOW | libc::O_NONBLOCK)
}

#[cfg(not(unix))]
fn guarded(opts: &mut OpenOptions) -> &mut OpenOptions {
    opts
}

/// Why a link is refused.
const LINK: &str = "it is a symbolic link (revelio follows no link in a run folder or a report)";

fn refused(message: String) -> io::Error {
    io::Error::new(io::ErrorKind::InvalidData, message)
}

/// Why `meta` (of a name in a run folder, not followed) is not a regular file, if it is not.
fn not_regular(meta: &Metadata) -> Option<io::Error> {
    if meta.file_type().is_symlink() {
        return Some(refused(LINK.into()));
    }
    (!meta.is_file()).then(|| refused(format!("it is {}, not a regular file", crate::source::file_kind(meta))))
}

/// Refuse `path` if it names anything but a regular file (a missing one is fine), judged
/// without following a link.
fn refuse_odd(path: &Path) -> io::Result<()> {
    match std::fs::symlink_metadata(path) {
        Ok(meta) => not_regular(&meta).map_or(Ok(()), Err),
        Err(e) if e.kind() == io::ErrorKind::NotFound => Ok(()),
        Err(e) => Err(e),
    }
}

/// Judge the name before opening (opening a FIFO may block; the link's message is clearer than
/// the OS's), then open with [`guarded`] flags and judge the handle again (the name may have
/// changed in between).
fn open_regular(path: &Path, opts: &mut OpenOptions) -> io::Result<File> {
    refuse_odd(path)?;
    let file = guarded(opts).open(path).map_err(link_error)?;
    if let Some(e) = not_regular(&file.metadata()?) {
        return Err(e);
    }
    Ok(file)
}

/// `ELOOP` from `O_NOFOLLOW` is a link that appeared after the check.
fn link_error(e: io::Error) -> io::Error {
    #[cfg(unix)]
    if e.raw_os_error() == Some(libc::ELOOP) {
        return refused(LINK.into());
    }
    e
}

/// Read `path`, a regular file (no link followed) of at most `limit` bytes.
pub fn read(path: &Path, limit: u64) -> io::Result<Vec<u8>> {
    let file = open_regular(path, OpenOptions::new().read(true))?;
    read_open(file, limit)
}

/// Read an opened file to its end, refusing more than `limit` bytes.
pub fn read_open(file: impl Read, limit: u64) -> io::Result<Vec<u8>> {
    let mut bytes = Vec::new();
    file.take(limit + 1).read_to_end(&mut bytes)?;
    if bytes.len() as u64 > limit {
        return Err(refused(format!("it is larger than {}, more than any run writes", size(limit))));
    }
    Ok(bytes)
}

/// [`read`] as UTF-8 text.
pub fn read_text(path: &Path, limit: u64) -> io::Result<String> {
    String::from_utf8(read(path, limit)?).map_err(|_| refused("it is not UTF-8 text".into()))
}

/// `64 MB`, `1 GB`, `4 KB`.
fn size(bytes: u64) -> String {
    match bytes {
        b if b >= 1 << 30 => format!("{} GB", b >> 30),
        b if b >= 1 << 20 => format!("{} MB", b >> 20),
        b => format!("{} KB", b >> 10),
    }
}

/// Open (creating it if absent) a regular file of a run folder for reading and writing, no link
/// followed; `append` for the journal.
pub fn open_rw(path: &Path, append: bool) -> io::Result<File> {
    let mut opts = OpenOptions::new();
    opts.read(true).create(true);
    if append {
        opts.append(true);
    } else {
        opts.write(true).truncate(false);
    }
    open_regular(path, &mut opts)
}

/// Make the folder `path` (its parent exists), or check that it is one: a link, even to a
/// folder, is refused, so nothing is written through it.
pub fn ensure_dir(path: &Path) -> io::Result<()> {
    match std::fs::create_dir(path) {
        Ok(()) => return Ok(()),
        Err(e) if e.kind() == io::ErrorKind::AlreadyExists => {}
        Err(e) => return Err(e),
    }
    let meta = std::fs::symlink_metadata(path)?;
    if meta.file_type().is_symlink() {
        return Err(refused(LINK.into()));
    }
    if !meta.is_dir() {
        return Err(refused(format!("it is {}, not a folder", crate::source::file_kind(&meta))));
    }
    Ok(())
}

/// Whether `path` names a symbolic link (not followed).
pub fn is_link(path: &Path) -> bool {
    std::fs::symlink_metadata(path).is_ok_and(|m| m.file_type().is_symlink())
}

/// Write `path` atomically: a new temporary file beside it (created, never opened through a
/// link), then renamed over it. A link or anything but a regular file at `path` is refused
/// rather than replaced.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> io::Result<()> {
    refuse_odd(path)?;
    let tmp = path.with_extension(format!("tmp{}", std::process::id()));
    let create = || guarded(OpenOptions::new().write(true).create_new(true)).open(&tmp);
    let mut file = match create() {
        // A temporary file left by a killed process of the same pid (or a planted name):
        // removing a link removes the link, never its target.
        Err(e) if e.kind() == io::ErrorKind::AlreadyExists => {
            std::fs::remove_file(&tmp)?;
            create()?
        }
        other => other?,
    };
    let written = file.write_all(bytes).and_then(|()| std::fs::rename(&tmp, path));
    if written.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    written
}

#[cfg(all(test, unix))]
mod tests {
    use super::*;

    #[test]
    fn links_fifos_devices_and_large_files_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("target.txt");
        std::fs::write(&target, "keep").unwrap();
        let link = dir.path().join("link");
        std::os::unix::fs::symlink(&target, &link).unwrap();
        for e in
            [read(&link, 10).unwrap_err(), open_rw(&link, true).unwrap_err(), write_atomic(&link, b"x").unwrap_err()]
        {
            assert!(e.to_string().contains("symbolic link"), "{e}");
        }
        assert_eq!(std::fs::read_to_string(&target).unwrap(), "keep");
        let zero = dir.path().join("zero");
        std::os::unix::fs::symlink("/dev/zero", &zero).unwrap();
        assert!(read(&zero, 10).unwrap_err().to_string().contains("symbolic link"));
        assert!(read(Path::new("/dev/zero"), 10).unwrap_err().to_string().contains("character device"));
        std::fs::write(dir.path().join("big"), "x".repeat(11)).unwrap();
        assert!(read(&dir.path().join("big"), 10).unwrap_err().to_string().contains("larger than"));
        assert_eq!(read(&dir.path().join("big"), 11).unwrap().len(), 11);
        let sub = dir.path().join("sub");
        std::os::unix::fs::symlink(dir.path(), &sub).unwrap();
        assert!(ensure_dir(&sub).unwrap_err().to_string().contains("symbolic link"));
        ensure_dir(&dir.path().join("real")).unwrap();
        ensure_dir(&dir.path().join("real")).unwrap();
        // A planted temporary name is removed (the link), not written through.
        let planted = dir.path().join(format!("out.tmp{}", std::process::id()));
        std::os::unix::fs::symlink(&target, &planted).unwrap();
        write_atomic(&dir.path().join("out.json"), b"new").unwrap();
        assert_eq!(std::fs::read_to_string(&target).unwrap(), "keep");
        assert_eq!(std::fs::read_to_string(dir.path().join("out.json")).unwrap(), "new");
    }
}
