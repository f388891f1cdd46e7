//! Every GLSL kernel and include under shaders/ names its Rust twin in a `Rust twin:` header, the twin exists,
//! and the shader's functions are the twin's: each function the shader defines is a Rust `fn` of the same name,
//! a method of the same name (`sampler_get` is `Sampler::get`, `recorder_hit` is the `hit` of `impl PathObserver
//! for Recorder`), a
//! constructor (`node_ray` is `NodeRay::new`), or listed in the shader's `GLSL only:` line with a reason.
//! Functions named in the header's parentheses must exist in the twin too. This keeps the pairing (docs/architecture.md)
//! checkable: a renamed Rust function or a shader helper without a counterpart fails here.

use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn shader_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            shader_files(&p, out);
        } else if p.extension().is_some_and(|x| x == "glsl" || x == "comp") {
            out.push(p);
        }
    }
}

/// Names of the functions a GLSL source defines (a return type, a name, parameters, a body).
fn glsl_functions(src: &str) -> Vec<String> {
    let mut out = vec![];
    for line in src.lines() {
        let t = line.trim_start();
        if line.starts_with(' ') || t.starts_with("//") || t.starts_with('#') || !t.ends_with('{') {
            continue;
        }
        let Some(open) = t.find('(') else { continue };
        let head: Vec<&str> = t[..open].split_whitespace().collect();
        if head.len() >= 2 && !["if", "for", "while", "switch", "struct", "layout"].contains(&head[0]) {
            let name = head[head.len() - 1];
            if name != "main" && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
                out.push(name.to_string());
            }
        }
    }
    out
}

fn camel(snake: &str) -> String {
    snake.split('_').map(|w| w[..1].to_uppercase() + &w[1..]).collect()
}

fn has_fn(rust: &str, name: &str) -> bool {
    rust.contains(&format!("fn {name}(")) || rust.contains(&format!("fn {name}<"))
}

/// The shader function `f` has a counterpart in `rust` (see the module).
fn twinned(rust: &str, f: &str) -> bool {
    if has_fn(rust, f) || (rust.contains(&format!("struct {} ", camel(f))) && has_fn(rust, "new")) {
        return true;
    }
    (1..f.len()).filter(|&i| &f[i..=i] == "_").any(|i| {
        let (ty, method) = (camel(&f[..i]), &f[i + 1..]);
        let implemented = [format!("impl {ty} "), format!("impl {ty}<"), format!("for {ty} "), format!("for {ty}<")];
        implemented.iter().any(|i| rust.contains(i.as_str())) && has_fn(rust, method)
    })
}

#[test]
fn every_shader_names_an_existing_twin_with_its_functions() {
    let mut files = vec![];
    shader_files(&root().join("shaders"), &mut files);
    files.sort();
    assert!(files.len() >= 12, "found {} shader files", files.len());
    let mut problems = vec![];
    for f in &files {
        let src = std::fs::read_to_string(f).unwrap();
        let name = f.strip_prefix(root()).unwrap().display().to_string();
        let Some(at) = src.find("Rust twin:") else {
            problems.push(format!("{name}: no `Rust twin:` header"));
            continue;
        };
        let rest = src[at + "Rust twin:".len()..].trim_start();
        let target = rest.split_whitespace().next().unwrap_or("").trim_end_matches([',', '.', ';']);
        if target == "glam's" || target == "glam" {
            continue; // vector helpers written as glam evaluates them: no file of ours to compare with
        }
        let twin_path = root().join(target);
        let Ok(rust) = std::fs::read_to_string(&twin_path) else {
            problems.push(format!("{name}: its twin {target} does not exist"));
            continue;
        };
        // Names listed in the header's parentheses, when they are a plain list of identifiers.
        let after = &rest[target.len()..];
        if let Some(list) = after.trim_start().strip_prefix('(').and_then(|l| l.split(')').next()) {
            let names: Vec<&str> = list.split(',').map(str::trim).collect();
            if names.iter().all(|n| !n.is_empty() && n.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')) {
                for n in names.iter().filter(|n| !has_fn(&rust, n)) {
                    problems.push(format!("{name}: the header names {n}, which {target} does not define"));
                }
            }
        }
        let glsl_only: Vec<&str> = src
            .lines()
            .filter_map(|l| l.split_once("GLSL only:").map(|(_, r)| r))
            .flat_map(|r| r.split(',').map(|w| w.split_whitespace().next().unwrap_or("")))
            .collect();
        for g in glsl_functions(&src) {
            if !glsl_only.contains(&g.as_str()) && !twinned(&rust, &g) {
                problems.push(format!("{name}: {g} has no counterpart in {target}"));
            }
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

/// The checker itself: a helper that is neither twinned nor declared GLSL-only is caught.
#[test]
fn the_checker_catches_an_untwinned_function() {
    let rust =
        "impl Sampler { pub fn get(&self) {} }\npub struct NodeRay { }\nimpl NodeRay { pub fn new() {} }\nfn dot3() {}";
    assert!(twinned(rust, "sampler_get") && twinned(rust, "node_ray") && twinned(rust, "dot3"));
    assert!(!twinned(rust, "sampler_put") && !twinned(rust, "helper"));
    let src = "float helper(float x) {\n    return x;\n}\nvoid main() {\n}\n";
    assert_eq!(glsl_functions(src), vec!["helper".to_string()]);
}
