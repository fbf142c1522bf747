//! Output paths, checked before any work (issue 14): a missing or read-only
//! folder, or an extension the command cannot write, is an error at once,
//! not after an hour of denoising. Every command that writes a mesh or a
//! picture calls [`check_file`] (or [`check_dir`] for an output folder)
//! first, and [`check_not_input`] when it also reads meshes; the folders
//! checked are remembered so that an interruption can remove this process's
//! temporary files from them ([`remove_temp_files`]).

use anyhow::bail;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// Extensions of the mesh writers (`normalnet_mesh::io::Format`).
pub const MESH: &[&str] = &["obj", "off", "ply", "stl", "gltf", "glb"];

/// Pictures: the rasterizer writes PNG only.
pub const PNG: &[&str] = &["png"];

/// Folders this process writes into (for [`remove_temp_files`]).
static FOLDERS: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

fn remember(dir: &Path) {
    let mut folders = FOLDERS.lock().unwrap_or_else(|e| e.into_inner());
    if !folders.iter().any(|d| d == dir) {
        folders.push(dir.to_path_buf());
    }
}

/// Checks that `path` can be written: its extension (case-insensitive) is
/// one of `extensions`, its folder exists and is writable, and it is not a
/// folder itself. `what` names the output in the error ("output mesh").
///
/// # Errors
/// A message naming the path and what is wrong.
pub fn check_file(path: &Path, extensions: &[&str], what: &str) -> anyhow::Result<()> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let list = extensions
        .iter()
        .map(|e| format!(".{e}"))
        .collect::<Vec<_>>()
        .join(", ");
    match ext {
        Some(e) if extensions.contains(&e.as_str()) => {}
        Some(e) => bail!(
            "{}: cannot write a .{e} {what}; the extension must be {list}",
            path.display()
        ),
        None => bail!(
            "{}: no extension; the {what} must end in {list}",
            path.display()
        ),
    }
    normalnet_mesh::io::check_writable(path)?;
    // a link is written through: the temporary file goes beside its target
    remember(&folder_of(&normalnet_mesh::io::write_target(path)));
    Ok(())
}

/// The file `path` names, links and `..` resolved, whether or not it exists
/// yet (its folder resolved, then its name joined); `path` itself when even
/// the folder cannot be resolved.
pub fn canonical(path: &Path) -> PathBuf {
    if let Ok(p) = std::fs::canonicalize(path) {
        return p;
    }
    let target = normalnet_mesh::io::write_target(path);
    match (
        std::fs::canonicalize(folder_of(&target)),
        target.file_name(),
    ) {
        (Ok(dir), Some(name)) => dir.join(name),
        _ => path.to_path_buf(),
    }
}

/// Refuses an output that is one of the `inputs` (same file after
/// resolving links and `..`): the atomic write would silently replace the
/// input the command reads.
///
/// # Errors
/// A message naming both paths.
pub fn check_not_input(output: &Path, inputs: &[&Path]) -> anyhow::Result<()> {
    let out = canonical(output);
    if let Some(input) = inputs.iter().find(|i| canonical(i) == out) {
        bail!(
            "{}: is the input {}; writing it would overwrite the input (choose another output)",
            output.display(),
            input.display()
        );
    }
    Ok(())
}

/// Checks that the output folder `dir` can be written: it is a writable
/// folder, or it does not exist yet and its nearest existing ancestor is a
/// writable folder (the command creates it).
///
/// # Errors
/// A message naming the folder and what is wrong.
pub fn check_dir(dir: &Path) -> anyhow::Result<()> {
    if dir.exists() && !dir.is_dir() {
        bail!("{}: exists and is not a folder", dir.display());
    }
    let mut existing = dir;
    while !existing.as_os_str().is_empty() && !existing.exists() {
        existing = existing.parent().unwrap_or(Path::new(""));
    }
    let probe_dir = if existing.as_os_str().is_empty() {
        Path::new(".")
    } else {
        existing
    };
    // A probe file name inside the folder: check_writable creates its
    // temporary file beside it.
    normalnet_mesh::io::check_writable(&probe_dir.join("probe"))?;
    remember(dir);
    Ok(())
}

/// The folder a file is written in (`.` for a bare name).
pub fn folder_of(path: &Path) -> PathBuf {
    match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

/// Removes this process's temporary files (`.normalnet-<pid>-*.tmp`, see
/// `normalnet_mesh::io::temp_prefix`) from the checked folders and their
/// direct sub-folders; returns how many were removed. Called on SIGINT /
/// SIGTERM, when no destructor runs.
pub fn remove_temp_files() -> usize {
    let prefix = normalnet_mesh::io::temp_prefix();
    let folders = FOLDERS.lock().unwrap_or_else(|e| e.into_inner()).clone();
    let mut removed = 0;
    let mut sweep = |dir: &Path, recurse: bool| {
        let Ok(entries) = std::fs::read_dir(dir) else {
            return Vec::new();
        };
        let mut subdirs = Vec::new();
        for entry in entries.flatten() {
            let name = entry.file_name();
            let name = name.to_string_lossy();
            if name.starts_with(&prefix) && name.ends_with(".tmp") {
                if std::fs::remove_file(entry.path()).is_ok() {
                    removed += 1;
                }
            } else if recurse && entry.file_type().is_ok_and(|t| t.is_dir()) {
                subdirs.push(entry.path());
            }
        }
        subdirs
    };
    for dir in &folders {
        for sub in sweep(dir, true) {
            sweep(&sub, false);
        }
    }
    removed
}

/// Removes from `dir` the temporary files of processes that no longer run
/// (`.normalnet-<pid>-*.tmp` whose process id is not a live process: a
/// SIGKILL, an out-of-memory kill or a power cut runs no handler and leaves
/// the file being written), so that a rerun into the folder leaves no
/// leftovers; returns how many were removed. This process's own files and
/// those of live processes are left alone. Linux only (liveness read from
/// `/proc`); elsewhere nothing is removed. A folder written by several
/// machines at once is not supported: another machine's process ids are
/// not visible here.
pub fn remove_stale_temp_files(dir: &Path) -> usize {
    if !Path::new("/proc/self").exists() {
        return 0;
    }
    let Ok(entries) = std::fs::read_dir(dir) else {
        return 0;
    };
    let own = std::process::id();
    let mut removed = 0;
    for entry in entries.flatten() {
        let name = entry.file_name();
        let name = name.to_string_lossy();
        let pid = name
            .strip_prefix(".normalnet-")
            .filter(|_| name.ends_with(".tmp"))
            .and_then(|rest| rest.split('-').next())
            .and_then(|pid| pid.parse::<u32>().ok());
        let Some(pid) = pid else { continue };
        let alive = pid == own || Path::new("/proc").join(pid.to_string()).exists();
        if !alive && std::fs::remove_file(entry.path()).is_ok() {
            removed += 1;
        }
    }
    removed
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn issue_14_output_checks_name_the_problem() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        check_file(&d.join("a.OBJ"), MESH, "output mesh").unwrap();
        check_file(&d.join("r.png"), PNG, "picture").unwrap();
        let e = check_file(&d.join("r.jpg"), PNG, "picture").unwrap_err();
        assert!(
            format!("{e:#}").contains("cannot write a .jpg picture; the extension must be .png"),
            "{e:#}"
        );
        let e = check_file(&d.join("out.xyz"), MESH, "output mesh").unwrap_err();
        assert!(
            format!("{e:#}").contains(".obj, .off, .ply, .stl, .gltf, .glb"),
            "{e:#}"
        );
        let e = check_file(&d.join("noext"), MESH, "output mesh").unwrap_err();
        assert!(format!("{e:#}").contains("no extension"), "{e:#}");
        let e = check_file(&d.join("missing/out.obj"), MESH, "output mesh").unwrap_err();
        assert!(format!("{e:#}").contains("missing"), "{e:#}");
        // Folders: existing, to be created, blocked by a file.
        check_dir(d).unwrap();
        check_dir(&d.join("new/deeper")).unwrap();
        std::fs::write(d.join("file"), b"x").unwrap();
        let e = check_dir(&d.join("file")).unwrap_err();
        assert!(format!("{e:#}").contains("not a folder"), "{e:#}");
        assert!(check_dir(&d.join("file/sub")).is_err());
        // Nothing was left behind by the probes.
        let names: Vec<_> = std::fs::read_dir(d)
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names, vec![std::ffi::OsString::from("file")]);
    }

    /// Audit: `denoise io.obj io.obj` silently overwrote its input.
    #[test]
    fn an_output_that_is_an_input_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let input = d.join("in.obj");
        std::fs::write(&input, b"v 0 0 0").unwrap();
        std::fs::create_dir(d.join("sub")).unwrap();
        let e = check_not_input(&input, &[&input]).unwrap_err();
        assert!(format!("{e:#}").contains("overwrite the input"), "{e:#}");
        // the same file under another spelling, or through a link
        assert!(check_not_input(&d.join("sub/../in.obj"), &[&input]).is_err());
        #[cfg(unix)]
        {
            let link = d.join("link.obj");
            std::os::unix::fs::symlink("in.obj", &link).unwrap();
            assert!(check_not_input(&link, &[&input]).is_err());
            assert!(check_not_input(&input, &[&link]).is_err());
        }
        // a new file, or another one, is fine
        check_not_input(&d.join("sub/in.obj"), &[&input]).unwrap();
        check_not_input(&d.join("out.obj"), &[&input, &d.join("gt.obj")]).unwrap();
    }

    #[test]
    fn issue_14_interrupted_temp_files_are_removed() {
        let dir = tempfile::tempdir().unwrap();
        let sub = dir.path().join("model");
        std::fs::create_dir(&sub).unwrap();
        check_dir(dir.path()).unwrap();
        let prefix = normalnet_mesh::io::temp_prefix();
        let ours = [
            dir.path().join(format!("{prefix}abc.tmp")),
            sub.join(format!("{prefix}def.tmp")),
        ];
        let theirs = dir.path().join(".normalnet-1-abc.tmp");
        for p in ours.iter().chain([&theirs]) {
            std::fs::write(p, b"half a mesh").unwrap();
        }
        assert_eq!(remove_temp_files(), 2);
        assert!(ours.iter().all(|p| !p.exists()));
        assert!(theirs.exists(), "another process's file is left alone");
    }

    /// Issue 39: a batch killed with SIGKILL (no handler runs) left its
    /// temporary file in the output folder for good.
    #[cfg(target_os = "linux")]
    #[test]
    fn issue_39_temp_files_of_dead_processes_are_removed() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        // a process that has exited: its id is free (and not reused this soon)
        let mut child = std::process::Command::new("true").spawn().unwrap();
        let dead = child.id();
        child.wait().unwrap();
        let stale = d.join(format!(".normalnet-{dead}-x1.tmp"));
        let own = d.join(format!("{}y2.tmp", normalnet_mesh::io::temp_prefix()));
        // pid 1 runs as long as the system does
        let live = d.join(".normalnet-1-z3.tmp");
        let others = [d.join("out.obj"), d.join(".normalnet-abc-q.tmp")];
        for p in [&stale, &own, &live].into_iter().chain(&others) {
            std::fs::write(p, b"half a mesh").unwrap();
        }
        assert_eq!(remove_stale_temp_files(d), 1);
        assert!(!stale.exists());
        assert!(own.exists() && live.exists() && others.iter().all(|p| p.exists()));
        assert_eq!(remove_stale_temp_files(&d.join("missing")), 0);
    }
}
