//! The documented Rhai API is the implemented one: every function scripts/README.md documents is called by
//! tests/scripts/api_tour.rhai (which checks what each returns and must run through), and every function the
//! engine registers is documented.

use psdr::backend::CpuBackend;
use psdr::script::{build_engine, run_script, RunContext, RunOptions, ScriptRun};
use psdr_tests::temp_dir;
use std::collections::BTreeSet;
use std::path::Path;

fn repo(rel: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(rel)
}

/// Function names in the README's API tables: `name(` and `x.name(` / `x.name` entries in backticks.
fn documented() -> BTreeSet<String> {
    let text = std::fs::read_to_string(repo("scripts/README.md")).unwrap();
    let api = &text[text.find("## API").expect("an API section")..];
    let mut names = BTreeSet::new();
    let mut in_function_table = false;
    for line in api.lines() {
        if line.starts_with("| function |") {
            in_function_table = true;
            continue;
        }
        if !line.starts_with('|') {
            in_function_table = false;
            continue;
        }
        if !in_function_table || !line.starts_with("| `") {
            continue;
        }
        let first = line.split('|').nth(1).unwrap_or("");
        for code in first.split('`').skip(1).step_by(2) {
            let code = ["s.", "r.", "t.", "obs."].iter().fold(code, |c, p| c.strip_prefix(p).unwrap_or(c));
            let name: String = code.chars().take_while(|c| c.is_ascii_alphanumeric() || *c == '_').collect();
            if name.chars().next().is_some_and(|c| c.is_ascii_alphabetic()) {
                names.insert(name);
            }
        }
    }
    names
}

#[test]
fn every_documented_function_is_exercised_and_every_registered_one_documented() {
    let doc = documented();
    for must in ["load_scene", "optimize", "gradient", "stage", "soft_iou", "texture_loss", "radiance", "mask"] {
        assert!(doc.contains(must), "the README parser missed '{must}': {doc:?}");
    }
    let tour = std::fs::read_to_string(repo("tests/scripts/api_tour.rhai")).unwrap();
    for name in &doc {
        let called = tour.contains(&format!("{name}(")) || tour.contains(&format!(".{name}"));
        assert!(called, "documented function '{name}' is not exercised by api_tour.rhai");
    }
    // Registered functions (getters appear as get$name, setters as set$name), operators excluded.
    let out = temp_dir("api-registered");
    let ctx = std::rc::Rc::new(std::cell::RefCell::new(RunContext::new(
        out,
        RunOptions::default(),
        Box::new(CpuBackend),
        Default::default(),
    )));
    let engine = build_engine(&ctx);
    let mut registered = BTreeSet::new();
    for sig in engine.gen_fn_signatures(false) {
        let name = sig.split('(').next().unwrap_or("");
        let name = name.strip_prefix("get$").or_else(|| name.strip_prefix("set$")).unwrap_or(name).to_string();
        if name.chars().next().is_some_and(|c| c.is_ascii_alphabetic()) && name != "to_string" {
            registered.insert(name);
        }
    }
    let undocumented: Vec<_> = registered.difference(&doc).collect();
    assert!(undocumented.is_empty(), "registered but not in scripts/README.md: {undocumented:?}");

    let dir = temp_dir("api-tour");
    let summary = run_script(
        ScriptRun {
            script: repo("tests/scripts/api_tour.rhai"),
            photo: repo("examples/fit/target.png"),
            out: dir.join("out"),
            sets: vec![],
            options: RunOptions {
                quiet: true,
                preview_spp: 2,
                db: Some(repo("examples/models")),
                ..Default::default()
            },
            command: "test".into(),
        },
        Box::new(CpuBackend),
    )
    .unwrap();
    assert_eq!(summary.stages, 1);
    let result: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("out/result.json")).unwrap()).unwrap();
    assert_eq!(result["recorded"]["tour"]["ok"], true);
    assert!(dir.join("out/tour/small.png").is_file() && dir.join("out/small.png").is_file());
}
