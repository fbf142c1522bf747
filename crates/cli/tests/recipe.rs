//! Issue 35 (and 39's killed `train --recipe`): the smoke recipe runs every
//! kind of stage; a run killed with SIGKILL twice (inside a checkpointed
//! network, then inside the switch rows) and run again ends with the
//! bundle of an uninterrupted run: the same network bytes and the same
//! manifest but for its wall-clock fields; the bundle loads and denoises;
//! the recipe edited reruns the edited stage and the later ones only;
//! another recipe is refused in that folder.
#![cfg(unix)]

mod common;

use common::{normalnet, s, stderr};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::Duration;

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn recipe() -> PathBuf {
    repo().join("configs/recipes/smoke.toml")
}

/// The recipe's data (its networks stages train on c3d/woody.obj).
fn data_present() -> bool {
    let woody = repo().join("../shared/data/c3d/woody.obj");
    if !woody.is_file() {
        println!("SKIP: no training data at {}", woody.display());
    }
    woody.is_file()
}

fn train(out: &Path) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_normalnet"));
    c.args([
        "-j",
        "2",
        "train",
        "-q",
        "--recipe",
        s(&recipe()),
        "--out",
        s(out),
    ]);
    c.env_remove("NORMALNET_MODEL");
    c
}

/// The manifest without its wall-clock fields (creation time, training
/// seconds, the notes that quote the run's seconds).
fn manifest_without_clock(dir: &Path) -> String {
    std::fs::read_to_string(dir.join("manifest.toml"))
        .unwrap()
        .lines()
        .filter(|l| {
            !(l.starts_with("created_unix")
                || l.starts_with("train_seconds")
                || l.starts_with("notes = \"continued from")
                || l.starts_with("notes = \"steps per network"))
        })
        .collect::<Vec<_>>()
        .join("\n")
}

/// Kills `child` (SIGKILL) as soon as `ready` holds; panics if it ended
/// first.
fn kill_when(child: &mut Child, what: &str, ready: impl Fn() -> bool) {
    loop {
        assert!(
            child.try_wait().unwrap().is_none(),
            "the run ended before {what}"
        );
        if ready() {
            child.kill().unwrap();
            child.wait().unwrap();
            return;
        }
        std::thread::sleep(Duration::from_millis(5));
    }
}

fn spawn(out: &Path) -> Child {
    train(out)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap()
}

#[test]
fn issue_35_a_killed_recipe_run_resumes_to_the_bundle_of_an_uninterrupted_one() {
    if !data_present() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let reference = dir.path().join("reference");
    let o = train(&reference).output().unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("evaluate validation: ran"), "{text}");
    assert!(
        text.contains("validation (smoke-suite.toml): all"),
        "{text}"
    );

    let killed = dir.path().join("killed");
    let more = killed.join("stages/02-more");
    let mut child = spawn(&killed);
    kill_when(
        &mut child,
        "a checkpoint of the second networks stage",
        || {
            std::fs::read_dir(more.join("checkpoint"))
                .is_ok_and(|mut d| d.any(|e| e.is_ok_and(|e| e.file_name() != "step-0")))
                && more.join("state.toml").is_file()
        },
    );
    assert!(!more.join("DONE").is_file());
    let rows = killed.join("stages/03-rows");
    let mut child = spawn(&killed);
    kill_when(&mut child, "the first rows file", || {
        rows.join("pair-0.bin").is_file()
    });
    assert!(!rows.join("DONE").is_file());
    let o = train(&killed).output().unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("networks networks: done before"), "{text}");
    assert!(text.contains("switch_rows rows: ran"), "{text}");

    for k in 1..=6 {
        let file = format!("net{k}.safetensors");
        assert!(
            std::fs::read(reference.join(&file)).unwrap()
                == std::fs::read(killed.join(&file)).unwrap(),
            "{file} differs after the resumed run"
        );
    }
    assert_eq!(
        manifest_without_clock(&reference),
        manifest_without_clock(&killed)
    );
    let manifest = std::fs::read_to_string(killed.join("manifest.toml")).unwrap();
    for key in [
        "[switch]",
        "[switch.late]",
        "[switch.heavy]",
        "[recipe]",
        "[evaluation]",
        "hash = \"",
    ] {
        assert!(manifest.contains(key), "{key} missing:\n{manifest}");
    }
    // the heavy table has the CNR candidate (five output biases), the main
    // table not (four)
    let parsed: toml::Value = toml::from_str(&manifest).unwrap();
    let biases = |t: &toml::Value| t["b2"].as_array().unwrap().len();
    assert_eq!(biases(&parsed["switch"]), 4);
    assert_eq!(biases(&parsed["switch"]["heavy"]["table"]), 5);

    // the bundle loads and denoises
    let clean = normalnet_voxel::shapes::generate_seeded(5, 300).unwrap();
    let input = dir.path().join("in.obj");
    normalnet_mesh::write_mesh(&input, &clean).unwrap();
    let output = dir.path().join("out.obj");
    let o = normalnet(&[
        "denoise",
        "-q",
        "--model",
        s(&killed),
        "--iterations",
        "2",
        s(&input),
        s(&output),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(output.is_file());

    // the same recipe edited (the switch tables' epochs): the stages before
    // the edit are kept, the edited one and every later one run again
    let edited = dir.path().join("recipes");
    std::fs::create_dir(&edited).unwrap();
    for f in ["smoke.toml", "smoke-more.toml", "smoke-suite.toml"] {
        std::fs::copy(repo().join("configs/recipes").join(f), edited.join(f)).unwrap();
    }
    std::fs::copy(
        repo().join("configs/train-smoke.toml"),
        dir.path().join("train-smoke.toml"),
    )
    .unwrap();
    let file = edited.join("smoke.toml");
    let text = std::fs::read_to_string(&file).unwrap();
    std::fs::write(&file, text.replace("epochs = 3", "epochs = 4")).unwrap();
    // --plan says so before anything runs
    let plan = |file: &Path| {
        let o = normalnet(&["train", "--recipe", s(file), "--out", s(&killed), "--plan"]);
        assert!(o.status.success(), "{}", stderr(&o));
        String::from_utf8_lossy(&o.stdout).into_owned()
    };
    let planned = plan(&file);
    for line in [
        "networks networks: done",
        "switch_rows rows: done",
        "switch_fit switch: changed",
        "evaluate validation: changed",
    ] {
        assert!(planned.contains(line), "{planned}");
    }
    let o = normalnet(&["train", "-q", "--recipe", s(&file), "--out", s(&killed)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8_lossy(&o.stdout);
    for kept in ["networks networks", "networks more", "switch_rows rows"] {
        assert!(text.contains(&format!("{kept}: done before")), "{text}");
    }
    for again in [
        "switch_fit switch",
        "switch_rows late-rows",
        "evaluate validation",
    ] {
        assert!(text.contains(&format!("{again}: ran")), "{text}");
    }
    for k in 1..=6 {
        let file = format!("net{k}.safetensors");
        assert!(
            std::fs::read(reference.join(&file)).unwrap()
                == std::fs::read(killed.join(&file)).unwrap(),
            "{file} changed though its stages did not"
        );
    }
    assert_ne!(
        manifest_without_clock(&reference),
        manifest_without_clock(&killed)
    );
    // run again unchanged: nothing runs
    assert!(!plan(&file).contains("changed") && !plan(&file).contains(": run"));
    let o = normalnet(&["train", "-q", "--recipe", s(&file), "--out", s(&killed)]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!String::from_utf8_lossy(&o.stdout).contains(": ran"));

    // another recipe (another name) is refused in that folder
    std::fs::write(
        &file,
        text_renamed(&std::fs::read_to_string(&file).unwrap()),
    )
    .unwrap();
    let o = normalnet(&["train", "-q", "--recipe", s(&file), "--out", s(&killed)]);
    assert!(!o.status.success());
    let err = stderr(&o);
    assert!(err.contains("holds a run of recipe \"smoke\""), "{err}");
}

fn text_renamed(text: &str) -> String {
    text.replacen("name = \"smoke\"", "name = \"other\"", 1)
}

#[test]
fn a_bad_recipe_is_refused_before_any_work() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("bad.toml");
    std::fs::write(
        &file,
        "name = \"bad\"\n[[stage]]\nkind = \"switch_fit\"\nname = \"fit\"\nrows = [\"rows\"]\n",
    )
    .unwrap();
    let out = dir.path().join("out");
    let o = normalnet(&["train", "-q", "--recipe", s(&file), "--out", s(&out)]);
    assert!(!o.status.success());
    let err = stderr(&o);
    assert!(
        err.contains("bad.toml")
            && err.contains("stage \"fit\"")
            && err.contains("no earlier switch_rows stage"),
        "{err}"
    );
    assert!(!out.exists(), "nothing written for a refused recipe");
    let o = normalnet(&[
        "train",
        "-q",
        "--recipe",
        s(&file),
        "--config",
        s(&file),
        "--out",
        s(&out),
    ]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("cannot be used with"), "{}", stderr(&o));
}

/// Issue 35: `configs/recipes/cnr.toml` rebuilds the shipped CNR model:
/// every number of `models/cnr/cnr.json` (stages, clusters, regressors) and
/// its training notes but for the last (the command and its seconds; the
/// recipe's notes end with the stage and the recipe instead). A CNR recipe
/// with another kind of stage is refused before any work.
#[test]
fn the_cnr_recipe_rebuilds_the_shipped_cnr_model() {
    if !repo().join("../shared/data/c3d/cow.obj").is_file() {
        println!("SKIP: no training data under ../shared/data");
        return;
    }
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("cnr");
    let recipe = repo().join("configs/recipes/cnr.toml");
    let o = normalnet(&["-q", "train", "--recipe", s(&recipe), "--out", s(&out)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let read = |p: &Path| -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap()
    };
    let (mut built, mut shipped) = (
        read(&out.join("cnr.json")),
        read(&repo().join("models/cnr/cnr.json")),
    );
    let notes = |v: &mut serde_json::Value| -> Vec<String> {
        let n: Vec<String> = serde_json::from_value(v["training"].take()).unwrap();
        n
    };
    let (built_notes, shipped_notes) = (notes(&mut built), notes(&mut shipped));
    assert!(
        built == shipped,
        "the model's numbers differ from models/cnr/cnr.json"
    );
    let kept = shipped_notes.len() - 1;
    assert_eq!(built_notes[..kept], shipped_notes[..kept]);
    assert!(
        built_notes[kept].starts_with("trained by stage \"cnr\""),
        "{built_notes:?}"
    );
    assert!(
        built_notes[kept + 1].starts_with("recipe "),
        "{built_notes:?}"
    );

    let mixed = tmp.path().join("mixed.toml");
    std::fs::write(
        &mixed,
        format!(
            "name = \"mixed\"\n[[stage]]\nkind = \"cnr\"\nname = \"c\"\nconfig = \"{}\"\n\
             [[stage]]\nkind = \"evaluate\"\nname = \"v\"\nsuite = \"{}\"\n",
            s(&repo().join("configs/train-lite.toml")),
            s(&repo().join("configs/validation.toml"))
        ),
    )
    .unwrap();
    let o = normalnet(&[
        "-q",
        "train",
        "--recipe",
        s(&mixed),
        "--out",
        s(&tmp.path().join("m")),
    ]);
    assert!(!o.status.success());
    assert!(
        stderr(&o).contains("only cnr stages, not evaluate"),
        "{}",
        stderr(&o)
    );
}
