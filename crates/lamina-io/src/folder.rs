//! Output folders that never destroy what lamina did not write.
//!
//! A command that writes a whole folder (a leaf folder, an exported scene) stages it: it
//! writes every file into a temporary sibling folder ([`stage`] → [`Staged::path`]) and then
//! [`Staged::commit`]s it. What commit does depends on what is at the target `dir`:
//!
//! | at `dir` | [`Replace::IfOurs`] | [`Replace::Force`] |
//! |---|---|---|
//! | nothing, or an empty folder | the staged folder is renamed to `dir` | same |
//! | a folder lamina wrote: its marker file says so and every entry is a name this kind of folder owns | the two folders are **exchanged** in one step, then the old files are removed by name | same |
//! | anything else (a foreign file, an unmarked or missing marker) | error naming the folder and the foreign files; nothing changed | the staged files are renamed into `dir` one by one, the marker last; every other file stays |
//! | a file, not a folder | error | error |
//!
//! In every case an output never replaces or removes one of the command's inputs
//! ([`FolderSpec::inputs`]): that is an error before anything changes.
//!
//! **What is guaranteed.** On Linux the exchange is `renameat2(RENAME_EXCHANGE)`: at every
//! moment `dir` is either the whole old folder or the whole new one. Where the platform or
//! file system cannot exchange (other systems, some network file systems), the old folder is
//! renamed aside and the new one renamed in: between those two renames, a few microseconds,
//! `dir` does not exist; if the second rename fails the old folder is renamed back. A forced
//! write into a foreign folder replaces each file atomically but not the folder as a whole (a
//! reader may see some new files beside old ones until the marker file, written last,
//! appears). Old files are only ever removed by name, one by one, and only names the folder
//! kind owns: a file that appears meanwhile is never deleted. A Ctrl-C during a commit waits
//! for it to finish ([`crate::interrupt::critical`]).

use crate::atomic::{Temporary, WriteError, sync_parent};
use crate::interrupt;
use std::path::{Path, PathBuf};

/// What a folder of one kind holds, and how lamina recognises one it wrote.
pub struct FolderSpec<'a> {
    /// What the folder is, in words, for messages ("leaf folder").
    pub kind: &'a str,
    /// Whether a file name is one that lamina writes in this kind of folder.
    pub owns: &'a dyn Fn(&str) -> bool,
    /// The file whose content marks the folder as written by lamina (e.g. `leaf.toml`).
    pub marker: &'a str,
    /// Whether the marker file at this path says lamina wrote it.
    pub is_marked: &'a dyn Fn(&Path) -> bool,
    /// The command's input files: never replaced or removed by the output.
    pub inputs: &'a [PathBuf],
}

/// How far a command may go when the target folder is not one lamina wrote.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Replace {
    /// Only replace a folder lamina wrote that holds nothing else (the default).
    IfOurs,
    /// Also write into a foreign folder, replacing only lamina's files and keeping the rest
    /// (`--force`).
    Force,
}

/// Why a folder was not written. Nothing was changed.
#[derive(Debug, thiserror::Error)]
pub enum FolderError {
    /// The target exists and is not a folder.
    #[error("'{dir}' exists and is not a folder")]
    NotAFolder {
        /// The target.
        dir: PathBuf,
    },
    /// The target holds files lamina did not write (and `--force` was not given).
    #[error(
        "'{dir}' is not a {kind} that lamina wrote: it holds {}; nothing was changed. \
         Choose a new or empty folder, or pass --force to write lamina's files into it \
         and keep every other file",
        list(.foreign, *.more)
    )]
    Foreign {
        /// The target.
        dir: PathBuf,
        /// What kind of folder was expected.
        kind: String,
        /// The first foreign entries (names, with why for the marker file).
        foreign: Vec<String>,
        /// How many more were not listed.
        more: usize,
    },
    /// Writing the folder would replace or remove one of the command's inputs.
    #[error(
        "'{input}' is an input of this command and would be overwritten by the {kind} '{dir}'; nothing was changed. Write the output to another folder"
    )]
    OverwritesInput {
        /// The input.
        input: PathBuf,
        /// The target.
        dir: PathBuf,
        /// What kind of folder.
        kind: String,
    },
    /// A file-system step failed.
    #[error("cannot write '{path}': {what}: {source}")]
    Io {
        /// The file or folder concerned.
        path: PathBuf,
        /// The step, in words.
        what: &'static str,
        /// The operating system's error.
        #[source]
        source: std::io::Error,
    },
}

fn list(names: &[String], more: usize) -> String {
    let mut s = names
        .iter()
        .map(|n| format!("'{n}'"))
        .collect::<Vec<_>>()
        .join(", ");
    if more > 0 {
        s.push_str(&format!(" and {more} more"));
    }
    s
}

impl From<WriteError> for FolderError {
    fn from(e: WriteError) -> Self {
        FolderError::Io {
            path: e.path,
            what: e.what,
            source: e.source,
        }
    }
}

/// What is at a target folder now.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum FolderState {
    /// Nothing, or an empty folder.
    New,
    /// A folder lamina wrote, holding only these (owned) entries.
    Ours(Vec<String>),
    /// A folder with foreign entries (listed) that `--force` lets lamina write into.
    Foreign(Vec<String>),
}

const LISTED: usize = 8;

/// Looks at `dir` and says what a commit would do, or why it would refuse; changes nothing.
/// Commands call it before their long work, so that a refusal comes at once.
pub fn check_folder(
    dir: &Path,
    spec: &FolderSpec,
    mode: Replace,
) -> Result<FolderState, FolderError> {
    let dir = resolve(dir);
    let meta = match std::fs::symlink_metadata(&dir) {
        Ok(m) => m,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(FolderState::New),
        Err(source) => {
            return Err(FolderError::Io {
                path: dir,
                what: "cannot look at the folder",
                source,
            });
        }
    };
    if !meta.is_dir() {
        return Err(FolderError::NotAFolder { dir });
    }
    let names = entries(&dir)?;
    if names.is_empty() {
        return Ok(FolderState::New);
    }
    let mut foreign: Vec<String> = names.iter().filter(|n| !(spec.owns)(n)).cloned().collect();
    let marker = dir.join(spec.marker);
    if !names.iter().any(|n| n == spec.marker) {
        foreign.push(format!("no {} written by lamina", spec.marker));
    } else if !(spec.is_marked)(&marker) {
        foreign.push(format!("{} (not written by lamina)", spec.marker));
    }
    if foreign.is_empty() {
        // Every owned file would be replaced or removed: none may be an input.
        for n in &names {
            check_not_input(&dir.join(n), &dir, spec)?;
        }
        return Ok(FolderState::Ours(names));
    }
    if mode == Replace::Force {
        return Ok(FolderState::Foreign(foreign));
    }
    let more = foreign.len().saturating_sub(LISTED);
    foreign.truncate(LISTED);
    Err(FolderError::Foreign {
        dir,
        kind: spec.kind.to_owned(),
        foreign,
        more,
    })
}

/// A folder being written: fill [`Staged::path`], then [`Staged::commit`]. Dropped without a
/// commit (an error, a panic), the staged folder is removed and `dir` is untouched.
#[derive(Debug)]
pub struct Staged {
    dir: PathBuf,
    tmp: Temporary,
    mode: Replace,
}

/// Checks `dir` ([`check_folder`]) and creates the temporary sibling folder to fill.
/// Creates `dir`'s parent folders if needed.
pub fn stage(dir: &Path, spec: &FolderSpec, mode: Replace) -> Result<Staged, FolderError> {
    check_folder(dir, spec, mode)?;
    let dir = resolve(dir);
    let parent = parent_of(&dir);
    std::fs::create_dir_all(&parent).map_err(|source| FolderError::Io {
        path: parent.clone(),
        what: "cannot create the parent folder",
        source,
    })?;
    let tmp = Temporary::sibling_of(&dir, true)?;
    std::fs::create_dir(tmp.path()).map_err(|source| FolderError::Io {
        path: tmp.path().to_owned(),
        what: "cannot create the temporary folder",
        source,
    })?;
    Ok(Staged { dir, tmp, mode })
}

impl Staged {
    /// The temporary folder to write every file of the output into.
    pub fn path(&self) -> &Path {
        self.tmp.path()
    }

    /// Puts the staged folder in place (see the module docs for what that means for each
    /// state of the target). Checks the target again first, since it may have changed while
    /// the files were written. Returns the folder's path.
    pub fn commit(self, spec: &FolderSpec) -> Result<PathBuf, FolderError> {
        // New files must not replace an input either (a forced write into a folder that
        // holds the command's input under an output's name).
        for n in entries(self.tmp.path())? {
            check_not_input(&self.dir.join(&n), &self.dir, spec)?;
        }
        let state = check_folder(&self.dir, spec, self.mode)?;
        interrupt::critical(|| match state {
            FolderState::New => self.commit_new(),
            FolderState::Ours(old) => self.commit_exchange(spec, &old),
            FolderState::Foreign(_) => self.commit_merge(spec),
        })
    }

    fn io(&self, what: &'static str) -> impl FnOnce(std::io::Error) -> FolderError + '_ {
        move |source| FolderError::Io {
            path: self.dir.clone(),
            what,
            source,
        }
    }

    fn commit_new(self) -> Result<PathBuf, FolderError> {
        // An empty folder at `dir` is replaced by the rename (POSIX); a non-empty one that
        // appeared since the check makes the rename fail, changing nothing.
        std::fs::rename(self.tmp.path(), &self.dir)
            .map_err(self.io("cannot rename the finished folder into place"))?;
        sync_parent(&self.dir);
        let Staged { dir, tmp, .. } = self;
        tmp.keep();
        Ok(dir)
    }

    fn commit_exchange(
        self,
        spec: &FolderSpec,
        old_names: &[String],
    ) -> Result<PathBuf, FolderError> {
        if exchange(self.tmp.path(), &self.dir).is_ok() {
            // The temporary path now holds the old folder: remove its files by name.
            sync_parent(&self.dir);
            let old = self.tmp.path().to_owned();
            remove_owned(&old, spec, old_names);
            let Staged { dir, tmp, .. } = self;
            if std::fs::remove_dir(&old).is_ok() {
                tmp.keep();
            } else {
                // Something we did not write appeared in the old folder: keep it all.
                tmp.keep();
                eprintln!(
                    "warning: the previous contents of '{}' were kept in '{}' (it holds files lamina did not write)",
                    dir.display(),
                    old.display()
                );
            }
            return Ok(dir);
        }
        // No exchange here: move the old folder aside, the new one in, the old one out.
        let aside = Temporary::sibling_of(&self.dir, true)?;
        std::fs::rename(&self.dir, aside.path())
            .map_err(self.io("cannot move the old folder aside"))?;
        if let Err(source) = std::fs::rename(self.tmp.path(), &self.dir) {
            // Put the old folder back; `aside` must not delete it.
            let back = std::fs::rename(aside.path(), &self.dir);
            aside.keep();
            if back.is_err() {
                return Err(FolderError::Io {
                    path: self.dir.clone(),
                    what: "cannot rename the finished folder into place, and the old folder is left under a temporary name beside it",
                    source,
                });
            }
            return Err(self.io("cannot rename the finished folder into place")(
                source,
            ));
        }
        sync_parent(&self.dir);
        remove_owned(aside.path(), spec, old_names);
        if std::fs::remove_dir(aside.path()).is_err() {
            eprintln!(
                "warning: the previous contents of '{}' were kept in '{}'",
                self.dir.display(),
                aside.path().display()
            );
        }
        aside.keep();
        let Staged { dir, tmp, .. } = self;
        tmp.keep();
        Ok(dir)
    }

    fn commit_merge(self, spec: &FolderSpec) -> Result<PathBuf, FolderError> {
        let mut names = entries(self.tmp.path())?;
        // The marker last: until it is there, the folder does not claim to be complete.
        names.sort_by_key(|n| n == spec.marker);
        for n in &names {
            std::fs::rename(self.tmp.path().join(n), self.dir.join(n)).map_err(|source| {
                FolderError::Io {
                    path: self.dir.join(n),
                    what: "cannot rename the new file into place",
                    source,
                }
            })?;
        }
        sync_parent(&self.dir.join(spec.marker));
        let Staged { dir, tmp, .. } = self;
        let _ = std::fs::remove_dir(tmp.path());
        tmp.keep();
        Ok(dir)
    }
}

/// Removes the entries `names` of `old` that the spec owns, one by one (never a whole tree).
fn remove_owned(old: &Path, spec: &FolderSpec, names: &[String]) {
    for n in names.iter().filter(|n| (spec.owns)(n)) {
        let _ = std::fs::remove_file(old.join(n));
    }
}

#[cfg(target_os = "linux")]
fn exchange(a: &Path, b: &Path) -> std::io::Result<()> {
    use rustix::fs::{CWD, RenameFlags, renameat_with};
    renameat_with(CWD, a, CWD, b, RenameFlags::EXCHANGE).map_err(std::io::Error::from)
}

#[cfg(not(target_os = "linux"))]
fn exchange(_: &Path, _: &Path) -> std::io::Result<()> {
    Err(std::io::ErrorKind::Unsupported.into())
}

fn check_not_input(target: &Path, dir: &Path, spec: &FolderSpec) -> Result<(), FolderError> {
    let Ok(t) = target.canonicalize() else {
        return Ok(());
    };
    for input in spec.inputs {
        if input.canonicalize().is_ok_and(|i| i == t) {
            return Err(FolderError::OverwritesInput {
                input: input.clone(),
                dir: dir.to_owned(),
                kind: spec.kind.to_owned(),
            });
        }
    }
    Ok(())
}

/// A symbolic link to a folder stands for the folder it points to.
fn resolve(dir: &Path) -> PathBuf {
    match std::fs::symlink_metadata(dir) {
        Ok(m) if m.file_type().is_symlink() => {
            dir.canonicalize().unwrap_or_else(|_| dir.to_owned())
        }
        _ => dir.to_owned(),
    }
}

fn parent_of(dir: &Path) -> PathBuf {
    match dir.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_owned(),
        _ => PathBuf::from("."),
    }
}

fn entries(dir: &Path) -> Result<Vec<String>, FolderError> {
    let rd = std::fs::read_dir(dir).map_err(|source| FolderError::Io {
        path: dir.to_owned(),
        what: "cannot list the folder",
        source,
    })?;
    let mut names = Vec::new();
    for e in rd {
        let e = e.map_err(|source| FolderError::Io {
            path: dir.to_owned(),
            what: "cannot list the folder",
            source,
        })?;
        names.push(e.file_name().to_string_lossy().into_owned());
    }
    names.sort();
    Ok(names)
}

#[cfg(test)]
mod tests {
    use super::*;

    const OWNED: [&str; 3] = ["a.png", "b.png", "leaf.toml"];

    fn owns(n: &str) -> bool {
        OWNED.contains(&n)
    }

    fn marked(p: &Path) -> bool {
        std::fs::read_to_string(p).is_ok_and(|s| s.contains("generator = \"lamina"))
    }

    fn spec(inputs: &[PathBuf]) -> FolderSpec<'_> {
        FolderSpec {
            kind: "leaf folder",
            owns: &owns,
            marker: "leaf.toml",
            is_marked: &marked,
            inputs,
        }
    }

    fn scratch(name: &str) -> PathBuf {
        let d =
            std::env::temp_dir().join(format!("lamina-io-folder-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    fn write(dir: &Path, tag: &str, mode: Replace) -> Result<PathBuf, FolderError> {
        let s = spec(&[]);
        let st = stage(dir, &s, mode)?;
        std::fs::write(st.path().join("a.png"), tag).unwrap();
        std::fs::write(
            st.path().join("leaf.toml"),
            format!("generator = \"lamina\"\n# {tag}"),
        )
        .unwrap();
        st.commit(&s)
    }

    fn names(d: &Path) -> Vec<String> {
        entries(d).unwrap()
    }

    #[test]
    fn new_then_replaced_when_ours() {
        let root = scratch("ours");
        let dir = root.join("leaf");
        write(&dir, "one", Replace::IfOurs).unwrap();
        assert_eq!(std::fs::read_to_string(dir.join("a.png")).unwrap(), "one");
        // An old owned file that the new write does not make is removed by name.
        std::fs::write(dir.join("b.png"), "old b").unwrap();
        write(&dir, "two", Replace::IfOurs).unwrap();
        assert_eq!(std::fs::read_to_string(dir.join("a.png")).unwrap(), "two");
        assert_eq!(names(&dir), ["a.png", "leaf.toml"]);
        // No temporary folder is left beside it.
        assert_eq!(names(&root), ["leaf"]);
    }

    #[test]
    fn foreign_files_refuse_without_force_and_survive_with_it() {
        let root = scratch("foreign");
        let dir = root.join("mine");
        std::fs::create_dir(&dir).unwrap();
        std::fs::write(dir.join("photo.jpg"), "holiday").unwrap();
        std::fs::write(dir.join("notes.txt"), "notes").unwrap();
        let e = write(&dir, "x", Replace::IfOurs).unwrap_err();
        let msg = e.to_string();
        assert!(
            msg.contains("photo.jpg") && msg.contains("notes.txt") && msg.contains("--force"),
            "{msg}"
        );
        assert_eq!(names(&dir), ["notes.txt", "photo.jpg"]);
        assert_eq!(names(&root), ["mine"]);
        write(&dir, "forced", Replace::Force).unwrap();
        assert_eq!(
            names(&dir),
            ["a.png", "leaf.toml", "notes.txt", "photo.jpg"]
        );
        assert_eq!(
            std::fs::read_to_string(dir.join("photo.jpg")).unwrap(),
            "holiday"
        );
        assert_eq!(names(&root), ["mine"]);
    }

    #[test]
    fn an_unmarked_leaf_toml_is_foreign() {
        let root = scratch("unmarked");
        let dir = root.join("hand");
        std::fs::create_dir(&dir).unwrap();
        std::fs::write(dir.join("leaf.toml"), "# written by hand").unwrap();
        std::fs::write(dir.join("a.png"), "hand-made").unwrap();
        let msg = write(&dir, "x", Replace::IfOurs).unwrap_err().to_string();
        assert!(msg.contains("leaf.toml (not written by lamina)"), "{msg}");
        assert_eq!(
            std::fs::read_to_string(dir.join("a.png")).unwrap(),
            "hand-made"
        );
    }

    #[test]
    fn an_input_is_never_overwritten_even_with_force() {
        let root = scratch("input");
        let dir = root.join("mine");
        std::fs::create_dir(&dir).unwrap();
        let photo = dir.join("a.png");
        std::fs::write(&photo, "the only copy").unwrap();
        let inputs = [photo.clone()];
        let s = spec(&inputs);
        let st = stage(&dir, &s, Replace::Force).unwrap();
        std::fs::write(st.path().join("a.png"), "derived").unwrap();
        let e = st.commit(&s).unwrap_err();
        assert!(matches!(e, FolderError::OverwritesInput { .. }), "{e}");
        assert_eq!(std::fs::read_to_string(&photo).unwrap(), "the only copy");
        assert_eq!(names(&root), ["mine"]);
        // A marked folder holding the input is refused at the check, before any work.
        std::fs::write(dir.join("leaf.toml"), "generator = \"lamina\"").unwrap();
        let e = check_folder(&dir, &s, Replace::IfOurs).unwrap_err();
        assert!(matches!(e, FolderError::OverwritesInput { .. }), "{e}");
    }

    #[test]
    fn a_file_in_the_way_is_an_error() {
        let root = scratch("file");
        let dir = root.join("leaf");
        std::fs::write(&dir, "a file").unwrap();
        let e = write(&dir, "x", Replace::Force).unwrap_err();
        assert!(matches!(e, FolderError::NotAFolder { .. }), "{e}");
        assert_eq!(std::fs::read_to_string(&dir).unwrap(), "a file");
    }

    #[test]
    fn a_dropped_stage_leaves_nothing() {
        let root = scratch("drop");
        let dir = root.join("leaf");
        let s = spec(&[]);
        let st = stage(&dir, &s, Replace::IfOurs).unwrap();
        std::fs::write(st.path().join("a.png"), "half").unwrap();
        drop(st);
        assert!(names(&root).is_empty());
    }

    #[test]
    fn an_empty_folder_is_new() {
        let root = scratch("empty");
        let dir = root.join("leaf");
        std::fs::create_dir(&dir).unwrap();
        assert_eq!(
            check_folder(&dir, &spec(&[]), Replace::IfOurs).unwrap(),
            FolderState::New
        );
        write(&dir, "one", Replace::IfOurs).unwrap();
        assert_eq!(names(&dir), ["a.png", "leaf.toml"]);
    }
}
