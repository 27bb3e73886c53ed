//! Output files written as one transaction, and the checks made on output
//! paths before any work is done.
//!
//! [`OutputSet`] stages every file of a run in a temporary file next to its
//! target and renames them all over their targets in [`OutputSet::commit`].
//! Dropped without a commit (an error, a panic), it removes its temporaries
//! and the directories it created, so a failed run leaves nothing behind.
//!
//! An existing target that is not a regular file (`/dev/null`, `/dev/full`,
//! a FIFO) is never renamed over: it is written in place at commit, and a
//! write error there (ENOSPC on `/dev/full`) is an error of the run. A
//! directory as a file target is refused.
//!
//! [`check_outputs`] refuses, before a run starts, an output that is also an
//! input, two outputs that are the same file, a missing parent directory and
//! a file output that is a directory. Paths are compared by identity: the
//! canonical path of an existing file, else the canonical parent joined with
//! the file name.

use std::fs::{self, File, OpenOptions};
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

use crate::IoError;

/// The identity of `path` for comparing outputs and inputs: its canonical
/// path if it exists, else its canonical parent directory joined with its
/// file name. An error when neither exists.
pub fn identity(path: &Path) -> io::Result<PathBuf> {
    if let Ok(c) = fs::canonicalize(path) {
        return Ok(c);
    }
    let name = path
        .file_name()
        .ok_or_else(|| io::Error::new(io::ErrorKind::InvalidInput, "not a file name"))?;
    Ok(fs::canonicalize(parent_of(path))?.join(name))
}

/// The directory holding `path` (`.` for a bare file name).
fn parent_of(path: &Path) -> &Path {
    match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    }
}

/// Whether two metadata describe the same file (device and inode on Unix;
/// elsewhere never, the paths are compared instead).
fn same_file(a: &fs::Metadata, b: &fs::Metadata) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        a.dev() == b.dev() && a.ino() == b.ino()
    }
    #[cfg(not(unix))]
    {
        let _ = (a, b);
        false
    }
}

/// What an output path will be.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OutputKind {
    /// A file (written whole, or in place for a device or FIFO).
    File,
    /// A directory of files (made by the run if it does not exist).
    Dir,
}

/// One output of a run: what the command line calls it (`-o`, `--report`),
/// its path and whether it is a file or a directory.
#[derive(Clone, Copy, Debug)]
pub struct OutputPath<'a> {
    /// The name the command line gives this output (`-o`, `--report`), used
    /// in error messages.
    pub label: &'a str,
    /// Where the output goes.
    pub path: &'a Path,
    /// Whether the output is a file or a directory.
    pub kind: OutputKind,
}

fn refuse(path: &Path, reason: impl Into<String>) -> IoError {
    IoError::Output {
        path: path.to_path_buf(),
        reason: reason.into(),
    }
}

/// Checks the outputs of a run before it starts: each one's parent directory
/// exists, a file output is not a directory, a directory output is not an
/// existing non-directory, and no output is one of `inputs` or another
/// output.
pub fn check_outputs(inputs: &[&Path], outputs: &[OutputPath]) -> Result<(), IoError> {
    let input_ids: Vec<(PathBuf, &Path)> = inputs
        .iter()
        .filter_map(|p| identity(p).ok().map(|id| (id, *p)))
        .collect();
    let input_metas: Vec<(fs::Metadata, &Path)> = inputs
        .iter()
        .filter_map(|p| fs::metadata(p).ok().map(|m| (m, *p)))
        .collect();
    let mut seen: Vec<(PathBuf, &str)> = Vec::new();
    for o in outputs {
        if o.path.file_name().is_none() {
            return Err(refuse(
                o.path,
                format!("{} needs a file or directory name", o.label),
            ));
        }
        let parent = parent_of(o.path);
        if !parent.is_dir() {
            return Err(refuse(
                o.path,
                format!(
                    "{}: the directory {} does not exist",
                    o.label,
                    parent.display()
                ),
            ));
        }
        let meta = fs::metadata(o.path).ok();
        match (o.kind, &meta) {
            (OutputKind::File, Some(m)) if m.is_dir() => {
                return Err(refuse(
                    o.path,
                    format!("{}: is a directory, not a file", o.label),
                ))
            }
            (OutputKind::Dir, Some(m)) if !m.is_dir() => {
                return Err(refuse(
                    o.path,
                    format!("{}: exists and is not a directory", o.label),
                ))
            }
            _ => {}
        }
        let id = identity(o.path).map_err(|source| IoError::Io {
            path: o.path.to_path_buf(),
            source,
        })?;
        let special = meta.as_ref().is_some_and(|m| !m.is_file() && !m.is_dir());
        if !special {
            let by_path = input_ids.iter().find(|(i, _)| *i == id).map(|x| x.1);
            // another name of the same file (a hard link)
            let by_inode = meta.as_ref().and_then(|m| {
                input_metas
                    .iter()
                    .find(|(im, _)| same_file(m, im))
                    .map(|x| x.1)
            });
            if let Some(input) = by_path.or(by_inode) {
                return Err(refuse(
                    o.path,
                    format!(
                        "{} is the input {}; refusing to overwrite an input",
                        o.label,
                        input.display()
                    ),
                ));
            }
        }
        if let Some((_, other)) = seen.iter().find(|(s, _)| *s == id) {
            return Err(refuse(
                o.path,
                format!(
                    "{} and {} name the same {}; give each output its own path",
                    other,
                    o.label,
                    if o.kind == OutputKind::Dir {
                        "directory"
                    } else {
                        "file"
                    }
                ),
            ));
        }
        seen.push((id, o.label));
    }
    Ok(())
}

/// A staged output file.
enum Pending {
    /// A complete temporary file, renamed over `target` at commit.
    Temp {
        tmp: PathBuf,
        target: PathBuf,
        shown: PathBuf,
        existed: bool,
    },
    /// An existing non-regular file (a device, a FIFO), written in place at
    /// commit.
    InPlace { target: PathBuf, bytes: Vec<u8> },
}

/// The files and directories of one run, written together or not at all
/// (see the module documentation).
#[derive(Default)]
pub struct OutputSet {
    pending: Vec<Pending>,
    /// Identities of the staged files, to refuse writing one twice.
    ids: Vec<PathBuf>,
    /// Directories this run created, in creation order.
    created_dirs: Vec<PathBuf>,
    /// Files of this run renamed into place (removed if a later rename of
    /// the same commit fails).
    placed: Vec<PathBuf>,
    committed: bool,
}

static COUNTER: AtomicUsize = AtomicUsize::new(0);

impl OutputSet {
    /// An empty set: nothing staged, no directory created.
    pub fn new() -> Self {
        Self::default()
    }

    /// Makes sure `dir` is a directory: creates it (its parent must exist)
    /// and removes it again if the run fails.
    pub fn dir(&mut self, dir: &Path) -> Result<(), IoError> {
        match fs::metadata(dir) {
            Ok(m) if m.is_dir() => Ok(()),
            Ok(_) => Err(refuse(dir, "exists and is not a directory")),
            Err(_) => {
                fs::create_dir(dir).map_err(|source| IoError::Io {
                    path: dir.to_path_buf(),
                    source,
                })?;
                self.created_dirs.push(dir.to_path_buf());
                Ok(())
            }
        }
    }

    /// Stages the file `path` with the content `body` writes.
    pub fn file(
        &mut self,
        path: &Path,
        body: impl FnOnce(&mut dyn Write) -> io::Result<()>,
    ) -> Result<(), IoError> {
        let err = |source: io::Error| IoError::Io {
            path: path.to_path_buf(),
            source,
        };
        let name = path
            .file_name()
            .ok_or_else(|| refuse(path, "not a file name"))?;
        let id = identity(path).map_err(err)?;
        if self.ids.contains(&id) {
            return Err(refuse(path, "this run would write the file twice"));
        }
        let meta = fs::metadata(path).ok();
        if let Some(m) = &meta {
            if m.is_dir() {
                return Err(refuse(path, "is a directory, not a file"));
            }
            if !m.is_file() {
                let mut bytes = Vec::new();
                body(&mut bytes).map_err(err)?;
                self.ids.push(id.clone());
                self.pending.push(Pending::InPlace { target: id, bytes });
                return Ok(());
            }
        }
        // an existing file is replaced where it lives (through symlinks)
        let target = if meta.is_some() {
            id.clone()
        } else {
            path.to_path_buf()
        };
        let tmp = parent_of(&target).join(format!(
            ".{}.{}.{}.tmp",
            name.to_string_lossy(),
            std::process::id(),
            COUNTER.fetch_add(1, Ordering::Relaxed)
        ));
        let file = OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&tmp)
            .map_err(err)?;
        // registered at once so that a failure below removes it
        self.pending.push(Pending::Temp {
            tmp,
            target,
            shown: path.to_path_buf(),
            existed: meta.is_some(),
        });
        let mut w = BufWriter::with_capacity(1 << 16, file);
        body(&mut w).map_err(err)?;
        let file: File = w.into_inner().map_err(|e| err(e.into_error()))?;
        file.sync_all().map_err(err)?;
        self.ids.push(id);
        Ok(())
    }

    /// Stages the file `path` holding `bytes`.
    pub fn bytes(&mut self, path: &Path, bytes: &[u8]) -> Result<(), IoError> {
        self.file(path, |w| w.write_all(bytes))
    }

    /// Writes every staged file into place: in-place targets first (the
    /// writes that can still fail), then the renames. On an error nothing
    /// of this run is left (files that did not exist before are removed).
    pub fn commit(mut self) -> Result<(), IoError> {
        for p in &self.pending {
            if let Pending::InPlace { target, bytes } = p {
                let r = OpenOptions::new()
                    .write(true)
                    .open(target)
                    .and_then(|mut f| f.write_all(bytes).and_then(|_| f.flush()));
                r.map_err(|source| IoError::Io {
                    path: target.clone(),
                    source,
                })?;
            }
        }
        let pending = std::mem::take(&mut self.pending);
        let mut rest = pending.into_iter();
        while let Some(p) = rest.next() {
            if let Pending::Temp {
                tmp,
                target,
                shown,
                existed,
            } = p
            {
                if let Err(source) = fs::rename(&tmp, &target) {
                    let _ = fs::remove_file(&tmp);
                    self.pending = rest.collect();
                    return Err(IoError::Io {
                        path: shown,
                        source,
                    });
                }
                if !existed {
                    self.placed.push(target);
                }
            }
        }
        self.committed = true;
        Ok(())
    }
}

impl Drop for OutputSet {
    fn drop(&mut self) {
        if self.committed {
            return;
        }
        for p in &self.pending {
            if let Pending::Temp { tmp, .. } = p {
                let _ = fs::remove_file(tmp);
            }
        }
        for f in &self.placed {
            let _ = fs::remove_file(f);
        }
        for d in self.created_dirs.iter().rev() {
            let _ = fs::remove_dir(d);
        }
    }
}

/// Writes `bytes` to `path` whole or not at all (a one-file [`OutputSet`]).
pub fn write_file(path: &Path, bytes: &[u8]) -> Result<(), IoError> {
    let mut out = OutputSet::new();
    out.bytes(path, bytes)?;
    out.commit()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> = fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    #[test]
    fn a_dropped_set_leaves_nothing_behind() {
        let dir = tempfile::tempdir().unwrap();
        let keep = dir.path().join("keep.txt");
        fs::write(&keep, "old").unwrap();
        {
            let mut out = OutputSet::new();
            out.dir(&dir.path().join("plots")).unwrap();
            out.bytes(&dir.path().join("plots/a.svg"), b"a").unwrap();
            out.bytes(&keep, b"new").unwrap();
            out.bytes(&dir.path().join("b.msh"), b"b").unwrap();
        }
        assert_eq!(names(dir.path()), ["keep.txt"]);
        assert_eq!(fs::read_to_string(&keep).unwrap(), "old");
    }

    #[test]
    fn a_committed_set_writes_every_file() {
        let dir = tempfile::tempdir().unwrap();
        let mut out = OutputSet::new();
        out.dir(&dir.path().join("plots")).unwrap();
        out.bytes(&dir.path().join("plots/a.svg"), b"a").unwrap();
        out.bytes(&dir.path().join("b.msh"), b"b").unwrap();
        out.commit().unwrap();
        assert_eq!(names(dir.path()), ["b.msh", "plots"]);
        assert_eq!(names(&dir.path().join("plots")), ["a.svg"]);
    }

    #[test]
    fn the_same_file_is_not_staged_twice() {
        let dir = tempfile::tempdir().unwrap();
        let mut out = OutputSet::new();
        out.bytes(&dir.path().join("a.msh"), b"a").unwrap();
        let e = out
            .bytes(&dir.path().join("./a.msh"), b"b")
            .unwrap_err()
            .to_string();
        assert!(e.contains("twice"), "{e}");
        drop(out);
        assert!(names(dir.path()).is_empty());
    }

    #[cfg(unix)]
    #[test]
    fn a_device_is_written_in_place_never_replaced() {
        use std::os::unix::fs::FileTypeExt;
        let null = Path::new("/dev/null");
        if !null.exists() {
            return;
        }
        write_file(null, b"hello").unwrap();
        assert!(fs::metadata(null).unwrap().file_type().is_char_device());
        let full = Path::new("/dev/full");
        if full.exists() {
            let e = write_file(full, &vec![0u8; 1 << 16]).unwrap_err();
            assert!(e.to_string().contains("/dev/full"), "{e}");
            assert!(fs::metadata(full).unwrap().file_type().is_char_device());
        }
    }

    #[test]
    fn outputs_are_checked_against_inputs_and_each_other() {
        let dir = tempfile::tempdir().unwrap();
        let input = dir.path().join("in.toml");
        fs::write(&input, "x").unwrap();
        let file = |label, path| OutputPath {
            label,
            path,
            kind: OutputKind::File,
        };
        let a = dir.path().join("a.msh");
        let dotted = dir.path().join(".").join("in.toml");
        let e = check_outputs(&[&input], &[file("-o", &a), file("--report", &dotted)])
            .unwrap_err()
            .to_string();
        assert!(e.contains("input"), "{e}");
        let e = check_outputs(&[&input], &[file("-o", &a), file("--report", &a)])
            .unwrap_err()
            .to_string();
        assert!(e.contains("-o and --report"), "{e}");
        let missing = dir.path().join("nonexist/r.json");
        let e = check_outputs(&[&input], &[file("--report", &missing)])
            .unwrap_err()
            .to_string();
        assert!(e.contains("does not exist"), "{e}");
        let e = check_outputs(&[&input], &[file("--report", dir.path())])
            .unwrap_err()
            .to_string();
        assert!(e.contains("is a directory"), "{e}");
        check_outputs(&[&input], &[file("-o", &a)]).unwrap();
        #[cfg(unix)]
        {
            let link = dir.path().join("link.toml");
            fs::hard_link(&input, &link).unwrap();
            let e = check_outputs(&[&input], &[file("--report", &link)])
                .unwrap_err()
                .to_string();
            assert!(e.contains("input"), "{e}");
        }
    }
}
