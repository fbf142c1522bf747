use super::*;

/// A recipe in a temporary folder beside a copy of the smoke training config.
fn recipe_in(dir: &Path, text: &str) -> Result<Recipe, DenoiseError> {
    let config = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../configs/train-smoke.toml"
    );
    std::fs::copy(config, dir.join("train.toml")).unwrap();
    let file = dir.join("r.toml");
    std::fs::write(&file, text).unwrap();
    Recipe::load(&file)
}

const NETWORKS: &str = r#"
name = "t"
[[stage]]
kind = "networks"
name = "nets"
config = "train.toml"
"#;

#[test]
fn a_recipe_reads_its_stages_in_order() {
    let dir = tempfile::tempdir().unwrap();
    let text = format!(
        "{NETWORKS}
[[stage]]
kind = \"switch_rows\"
name = \"rows\"
networks = \"nets\"
iterations = 2
pairs = [{{ mesh = \"shape:60\", gaussian = [0.3] }}]

[[stage]]
kind = \"switch_fit\"
name = \"fit\"
rows = [\"rows\", \"rows\"]
epochs = 2
"
    );
    let r = recipe_in(dir.path(), &text).unwrap();
    let kinds: Vec<&str> = r.stages.iter().map(Stage::kind).collect();
    assert_eq!(kinds, ["networks", "switch_rows", "switch_fit"]);
    let Stage::SwitchRows(rows) = &r.stages[1] else {
        panic!("rows")
    };
    let Stage::SwitchFit(fit) = &r.stages[2] else {
        panic!("fit")
    };
    assert_eq!(
        fit.network_on_folds, None,
        "unset: the fitted table has no fold rule"
    );
    assert_eq!(
        (rows.mu_g, rows.vertex_iterations, rows.int8),
        (0.35, 20, true)
    );
    assert!(r.stage_dir(Path::new("out"), 2).ends_with("stages/03-fit"));
    // the stage hashes: comments and layout do not count, an edit changes
    // the edited stage's and every later one's, never an earlier one's
    let stages = r.stage_hashes().unwrap();
    let whole = r.hash().unwrap();
    assert_eq!(stages.len(), 3);
    let commented = text.replace("epochs = 2", "# fewer\nepochs   =   2");
    let same = recipe_in(dir.path(), &commented).unwrap();
    assert_eq!(same.stage_hashes().unwrap(), stages);
    assert_ne!(same.hash().unwrap(), whole, "the whole hash reads the text");
    let edited = recipe_in(
        dir.path(),
        &text.replace("iterations = 2", "iterations = 3"),
    )
    .unwrap();
    let changed = edited.stage_hashes().unwrap();
    assert_eq!(changed[0], stages[0]);
    assert!(changed[1] != stages[1] && changed[2] != stages[2]);
    // the hash covers the config the recipe names, and so does the first
    // stage's (and with it every later one's)
    let before = r.hash().unwrap();
    std::fs::write(
        dir.path().join("train.toml"),
        "preset = \"lite\"\nseed = 9\n",
    )
    .unwrap();
    assert_ne!(r.hash().unwrap(), before);
    let retrained = r.stage_hashes().unwrap();
    assert!(retrained.iter().zip(&stages).all(|(a, b)| a != b));
}

#[test]
fn bad_recipes_are_refused_naming_the_stage() {
    let dir = tempfile::tempdir().unwrap();
    let refused = |extra: &str, expected: &str| {
        let err = recipe_in(dir.path(), &format!("{NETWORKS}{extra}"))
            .unwrap_err()
            .to_string();
        assert!(err.contains(expected), "{extra}: {err}");
    };
    refused(
        "[[stage]]\nkind = \"switch_fit\"\nname = \"fit\"\nrows = [\"nets\"]\n",
        "rows \"nets\" is a networks stage, expected switch_rows",
    );
    refused(
        "[[stage]]\nkind = \"switch_fit\"\nname = \"fit\"\nrows = [\"later\"]\n",
        "rows \"later\" is no earlier switch_rows stage",
    );
    refused(
        "[[stage]]\nkind = \"networks\"\nname = \"nets\"\nconfig = \"train.toml\"\n",
        "stage \"nets\": the name is used twice",
    );
    refused(
        "[[stage]]\nkind = \"switch_rows\"\nname = \"rows\"\nnetworks = \"nets\"\npairs = [{ mesh = \"gd/Fandisk0.3/Original.obj\", gaussian = [0.3] }]\n",
        "Fandisk0.3",
    );
    refused(
        "[[stage]]\nkind = \"switch_rows\"\nname = \"rows\"\nnetworks = \"nets\"\npairs = []\n",
        "no pairs",
    );
    refused(
        "[[stage]]\nkind = \"switch_rows\"\nname = \"rows\"\nnetworks = \"nets\"\npairs = [{ mesh = \"shape:1\", gaussian = [0.3] }]\n[[stage]]\nkind = \"switch_fit\"\nname = \"late\"\nrows = [\"rows\"]\nlate = true\nmin_iteration = 11\n",
        "a late table needs an earlier main switch_fit stage",
    );
    refused(
        "[[stage]]\nkind = \"switch_rows\"\nname = \"rows\"\nnetworks = \"nets\"\npairs = [{ mesh = \"shape:1\", gaussian = [0.3] }]\n[[stage]]\nkind = \"switch_fit\"\nname = \"main\"\nrows = [\"rows\"]\n[[stage]]\nkind = \"switch_fit\"\nname = \"late\"\nrows = [\"rows\"]\nlate = true\nmin_iteration = 11\nnetwork_on_folds = true\n",
        "stage \"late\": network_on_folds is set on the main table",
    );
    refused(
        "[[stage]]\nkind = \"switch_rows\"\nname = \"rows\"\nnetworks = \"nets\"\npairs = [{ mesh = \"shape:1\", gaussian = [0.3] }]\n[[stage]]\nkind = \"switch_fit\"\nname = \"heavy\"\nrows = [\"rows\"]\nheavy_from = 1.0\n",
        "a heavy table needs an earlier main switch_fit stage",
    );
    for (extra, expected) in [
        (
            "heavy_from = 1.0\nnetwork_on_folds = true\n",
            "network_on_folds is set on the main table",
        ),
        (
            "heavy_from = 1.0\nlate = true\nmin_iteration = 11\n",
            "late or heavy, not both",
        ),
        ("heavy_from = -1.0\n", "heavy_from must be a positive angle"),
    ] {
        refused(
            &format!(
                "[[stage]]\nkind = \"switch_rows\"\nname = \"rows\"\nnetworks = \"nets\"\npairs = [{{ mesh = \"shape:1\", gaussian = [0.3] }}]\n[[stage]]\nkind = \"switch_fit\"\nname = \"main\"\nrows = [\"rows\"]\n[[stage]]\nkind = \"switch_fit\"\nname = \"heavy\"\nrows = [\"rows\"]\n{extra}"
            ),
            expected,
        );
    }
    // a table with the CNR candidate needs rows traced with it
    refused(
        "[[stage]]\nkind = \"switch_rows\"\nname = \"rows\"\nnetworks = \"nets\"\npairs = [{ mesh = \"shape:1\", gaussian = [0.3] }]\n[[stage]]\nkind = \"switch_fit\"\nname = \"main\"\nrows = [\"rows\"]\ncnr = true\n",
        "needs rows traced with it: give stage \"rows\" cnr = true",
    );
    refused(
        "[[stage]]\nkind = \"evaluate\"\nname = \"e\"\nsuite = \"missing.toml\"\n",
        "missing.toml",
    );
    refused(
        "[[stage]]\nkind = \"train\"\nname = \"x\"\n",
        "unknown variant",
    );
    refused(
        "[[stage]]\nkind = \"networks\"\nname = \"n2\"\nconfig = \"train.toml\"\nwarm = 1\n",
        "unknown field",
    );
    let err = recipe_in(dir.path(), "name = \"t\"\nstage = []\n")
        .unwrap_err()
        .to_string();
    assert!(err.contains("no [[stage]]"), "{err}");
}

#[test]
fn the_shipped_recipes_load() {
    let recipes = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../configs/recipes");
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/train");
    if !data.is_dir() {
        println!(
            "SKIP: no training data at {} (the suites name it)",
            data.display()
        );
        return;
    }
    for name in [
        "lite.toml",
        "lite-broad.toml",
        "lite-broad-cad.toml",
        "lite-broad-regen.toml",
        "lite-mix3-refit.toml",
        "lite-mix3-heavy.toml",
        "lite-heavy-switch.toml",
        "lite-cnr-switch.toml",
        "lite-cnr-control.toml",
        "lite-mix3-cnr-heavy.toml",
        "lite-narrow.toml",
        "smoke.toml",
    ] {
        let r = Recipe::load(&recipes.join(name)).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert!(r.stages.iter().any(|s| s.kind() == "evaluate"), "{name}");
        r.hash().unwrap();
    }
}

#[test]
fn a_recipe_never_trains_on_its_validation_pairs() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("suite.toml"),
        "groups = [\"g\"]\n[[pair]]\nname = \"p\"\nsource = \"shape:61\"\ngroups = [\"g\"]\nnoise = [{ level = 0.3, seed = 1 }]\n",
    )
    .unwrap();
    let text = format!(
        "{NETWORKS}
[[stage]]
kind = \"switch_rows\"
name = \"rows\"
networks = \"nets\"
pairs = [{{ mesh = \"shape:61\", gaussian = [0.3] }}]

[[stage]]
kind = \"evaluate\"
name = \"e\"
suite = \"suite.toml\"
"
    );
    let err = recipe_in(dir.path(), &text).unwrap_err().to_string();
    assert!(
        err.contains("stage \"rows\"")
            && err.contains("shape:61 is a pair of the validation suite suite.toml"),
        "{err}"
    );
}

/// A recipe may take a bundle's networks and switch tables as they are
/// (`bundle`): the bundle it assembles has the same networks and tables,
/// and a stage that both trains and takes is refused.
#[test]
fn a_recipe_takes_a_bundles_networks_and_tables() {
    let lite = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../models/lite");
    let dir = tempfile::tempdir().unwrap();
    let text = format!(
        "name = \"t\"
[[stage]]
kind = \"networks\"
name = \"shipped\"
bundle = {lite:?}

[[stage]]
kind = \"switch_fit\"
name = \"main\"
bundle = {lite:?}

[[stage]]
kind = \"switch_fit\"
name = \"late\"
bundle = {lite:?}
late = true
",
        lite = lite.display().to_string()
    );
    let r = recipe_in(dir.path(), &text).unwrap();
    let out = dir.path().join("out");
    let outcome = run(&r.file, &out, &normalnet_mesh::NoProgress).unwrap();
    let manifest = outcome.manifest.unwrap();
    let shipped =
        normalnet_net::bundle::Manifest::read(&lite.join(normalnet_net::bundle::MANIFEST)).unwrap();
    assert_eq!(manifest.switch, shipped.switch);
    for i in 0..6 {
        let name = normalnet_net::bundle::network_file(i);
        assert!(
            std::fs::read(out.join(&name)).unwrap() == std::fs::read(lite.join(&name)).unwrap()
        );
    }
    // the bundle's files are part of the recipe's hash
    assert_ne!(r.hash().unwrap(), {
        let plain = recipe_in(dir.path(), NETWORKS).unwrap();
        plain.hash().unwrap()
    });
    for (stage, expected) in [
        (
            format!(
                "[[stage]]\nkind = \"networks\"\nname = \"n\"\nbundle = {:?}\nconfig = \"train.toml\"\n",
                lite.display().to_string()
            ),
            "from `bundle` or trains them by `config`, not both",
        ),
        (
            "[[stage]]\nkind = \"networks\"\nname = \"n\"\nbundle = \"nowhere\"\n".to_string(),
            "bundle:",
        ),
        (
            format!(
                "{NETWORKS}[[stage]]\nkind = \"switch_fit\"\nname = \"f\"\nbundle = \"nowhere\"\n"
            ),
            "bundle:",
        ),
    ] {
        let text = if stage.starts_with('\n') {
            stage
        } else {
            format!("name = \"t\"\n{stage}")
        };
        let err = recipe_in(dir.path(), &text).unwrap_err().to_string();
        assert!(err.contains(expected), "{err}");
    }
}

/// `slots`: per network slot the network of an earlier `networks` stage,
/// with its manifest entry; stages whose networks are read differently,
/// or slots that are not six earlier networks stages, are refused.
#[test]
fn a_recipe_mixes_the_networks_of_two_stages_by_slot() {
    use normalnet_net::bundle::{MANIFEST, Manifest, network_file};
    let lite = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../models/lite");
    let dir = tempfile::tempdir().unwrap();
    // a second bundle: the shipped one with its entries marked
    let other = dir.path().join("other");
    std::fs::create_dir(&other).unwrap();
    for i in 0..6 {
        std::fs::copy(lite.join(network_file(i)), other.join(network_file(i))).unwrap();
    }
    let mut marked = Manifest::read(&lite.join(MANIFEST)).unwrap();
    for n in &mut marked.networks {
        n.steps = 12_345;
    }
    marked.write(&other.join(MANIFEST)).unwrap();
    let stages = |slots: &str| {
        format!(
            "name = \"t\"
[[stage]]
kind = \"networks\"
name = \"a\"
bundle = {lite:?}

[[stage]]
kind = \"networks\"
name = \"b\"
bundle = {other:?}

[[stage]]
kind = \"networks\"
name = \"mixed\"
slots = {slots}
",
            lite = lite.display().to_string(),
            other = other.display().to_string()
        )
    };
    let r = recipe_in(dir.path(), &stages(r#"["a", "b", "a", "b", "b", "a"]"#)).unwrap();
    let out = dir.path().join("out");
    let manifest = run(&r.file, &out, &normalnet_mesh::NoProgress)
        .unwrap()
        .manifest
        .unwrap();
    let shipped = Manifest::read(&lite.join(MANIFEST)).unwrap();
    for (k, from_b) in [false, true, false, true, true, false].iter().enumerate() {
        let want = if *from_b {
            12_345
        } else {
            shipped.networks[k].steps
        };
        assert_eq!(manifest.networks[k].steps, want, "slot {}", k + 1);
        assert!(
            std::fs::read(out.join(network_file(k))).unwrap()
                == std::fs::read(lite.join(network_file(k))).unwrap()
        );
    }
    assert!(
        manifest
            .training
            .notes
            .starts_with("networks by slot: 1 from stage a, 2 from stage b")
    );
    assert!(manifest.switch.is_none());
    for (slots, expected) in [
        (r#"["a", "b"]"#, "slots names 2 stages"),
        (
            r#"["a", "b", "a", "b", "a", "c"]"#,
            "\"c\" is no earlier networks stage",
        ),
        (
            r#"["a", "b", "a", "b", "a", "mixed"]"#,
            "\"mixed\" is no earlier networks stage",
        ),
    ] {
        let err = recipe_in(dir.path(), &stages(slots))
            .unwrap_err()
            .to_string();
        assert!(err.contains(expected), "{err}");
    }
    let both = stages(r#"["a", "b", "a", "b", "a", "b"]"#).replace(
        "name = \"mixed\"\n",
        "name = \"mixed\"\nconfig = \"train.toml\"\n",
    );
    let err = recipe_in(dir.path(), &both).unwrap_err().to_string();
    assert!(err.contains("one of them"), "{err}");
    // networks read differently (another preset) are refused when the stage runs
    let tiny = dir.path().join("tiny");
    let nets: Vec<_> = (0..6)
        .map(|i| normalnet_net::ModelConfig::tiny().init_weights(i))
        .collect();
    normalnet_net::bundle::save_bundle(
        &tiny,
        &normalnet_net::bundle::new_manifest("tiny").unwrap(),
        &nets,
    )
    .unwrap();
    std::fs::remove_dir_all(&other).unwrap();
    std::fs::rename(&tiny, &other).unwrap();
    let r = recipe_in(dir.path(), &stages(r#"["a", "b", "a", "b", "a", "b"]"#)).unwrap();
    let err = run(
        &r.file,
        &dir.path().join("out2"),
        &normalnet_mesh::NoProgress,
    )
    .unwrap_err()
    .to_string();
    assert!(
        err.contains("slot 2: stage \"b\"'s networks are not read as stage \"a\"'s"),
        "{err}"
    );
}
