//! The psdr crate's modules form layers and every `crate::` path points down them (docs/architecture.md): a
//! module may use only modules of a lower layer. The one edge against the grain is `backend` -> `grad`, and it
//! is limited to grad's term API for devices (layouts, adjoint types, the host-side pieces the kernels share):
//! the backend offers kernels, grad's orchestration chooses them or the CPU terms, and the backend never calls
//! a CPU gradient term itself.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

/// Each top-level module of psdr/src and its layer (0 = the bottom). A new module must be placed here.
const LAYERS: [(&str, u32); 20] = [
    ("error", 0),
    ("progress", 0),
    ("base", 1),
    ("models", 1),
    ("scene", 2),
    ("loss", 2),
    ("render", 3),
    ("output", 4),
    ("backend", 5),
    ("export", 5),
    ("grad", 6),
    ("vision", 6),
    ("optim", 7),
    ("db", 7),
    ("report", 8),
    ("stages", 9),
    ("script", 10),
    ("cli", 11),
    ("lib", 12),
    ("main", 12),
];

/// What `backend` may use of `grad`: the layouts and adjoint types its kernels take, and the host-side pieces
/// (edge lists, mask adjoints, texture read adjoints) the kernels share with the CPU terms.
const GRAD_TERM_API: [&str; 10] = [
    "AovAdjoints",
    "DeviceSlots",
    "GradLayout",
    "PixelwiseAdjoint",
    "PoseLayout",
    "PrimaryEdges",
    "SecondaryEdges",
    "masks_by_object",
    "normal_read_adjoint",
    "texture_read_adjoint",
];

fn layer(module: &str) -> Option<u32> {
    LAYERS.iter().find(|(m, _)| *m == module).map(|(_, l)| *l)
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap().flatten() {
        let p = e.path();
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

/// The text without `//` comments (a comment may name a module without using it).
fn code_only(text: &str) -> String {
    text.lines().map(|l| l.split_once("//").map_or(l, |(code, _)| code)).collect::<Vec<_>>().join("\n")
}

/// Every path after `crate::`, as its segments: `crate::a::B` gives [a, B]; a group `crate::{a::X, b::{Y, Z}}`
/// gives [a, X], [b, Y], [b, Z].
fn crate_paths(code: &str) -> Vec<Vec<String>> {
    let mut out = vec![];
    let mut rest = code;
    while let Some(i) = rest.find("crate::") {
        let after = &rest[i + "crate::".len()..];
        let (paths, used) = path_tree(after);
        out.extend(paths);
        rest = &after[used.max(1)..];
    }
    out
}

/// The paths of one use tree at the start of `s` (`a::b::C`, `a::{B, c::D}`, `{a, b}`) and the bytes read.
fn path_tree(s: &str) -> (Vec<Vec<String>>, usize) {
    let ident_len = s.find(|c: char| !(c.is_alphanumeric() || c == '_')).unwrap_or(s.len());
    if ident_len == 0 {
        if !s.starts_with('{') {
            return (vec![], 0);
        }
        let mut paths = vec![];
        let mut pos = 1;
        loop {
            let skip = s[pos..].len() - s[pos..].trim_start().len();
            pos += skip;
            if s[pos..].starts_with('}') || pos >= s.len() {
                return (paths, pos + 1);
            }
            let (inner, used) = path_tree(&s[pos..]);
            paths.extend(inner);
            pos += used.max(1);
            let skip = s[pos..].len() - s[pos..].trim_start().len();
            pos += skip;
            if s[pos..].starts_with(',') {
                pos += 1;
            }
        }
    }
    let ident = s[..ident_len].to_string();
    if let Some(tail) = s[ident_len..].strip_prefix("::") {
        let (inner, used) = path_tree(tail);
        if inner.is_empty() {
            return (vec![vec![ident]], ident_len);
        }
        let paths = inner.into_iter().map(|p| std::iter::once(ident.clone()).chain(p).collect()).collect();
        return (paths, ident_len + 2 + used);
    }
    // `crate::a as b` and plain `crate::a`.
    (vec![vec![ident]], ident_len)
}

/// The module a path into the crate root names (`crate::Error` and `crate::Result` are `error`'s).
fn module_of(path: &[String]) -> String {
    match path[0].as_str() {
        "Error" | "Result" => "error".to_string(),
        m => m.to_string(),
    }
}

#[test]
fn crate_paths_reads_use_trees() {
    let code = "use crate::{a::X, b::{Y, c::Z}};\nlet v = crate::d::f(1);\nuse crate::e as g;";
    let got = crate_paths(code);
    let want: Vec<Vec<&str>> = vec![vec!["a", "X"], vec!["b", "Y"], vec!["b", "c", "Z"], vec!["d", "f"], vec!["e"]];
    assert_eq!(got, want.iter().map(|p| p.iter().map(|s| s.to_string()).collect::<Vec<_>>()).collect::<Vec<_>>());
    assert_eq!(code_only("let a = 1; // crate::x::Y\n"), "let a = 1; ");
}

#[test]
fn every_module_uses_only_lower_layers() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("../psdr/src");
    let mut files = vec![];
    rust_files(&src, &mut files);
    files.sort();
    let mut wrong = BTreeSet::new();
    let mut backend_grad = BTreeSet::new();
    for f in &files {
        let rel = f.strip_prefix(&src).unwrap();
        let first = rel.components().next().unwrap().as_os_str().to_string_lossy().into_owned();
        let module = first.trim_end_matches(".rs").to_string();
        let Some(own) = layer(&module) else {
            wrong.insert(format!("{module}: not in LAYERS (place the new module in a layer)"));
            continue;
        };
        let text = std::fs::read_to_string(f).unwrap();
        for path in crate_paths(&code_only(&text)) {
            let used = module_of(&path);
            if used == module {
                continue;
            }
            if module == "backend" && used == "grad" {
                let item = path.get(1).cloned().unwrap_or_default();
                if path.len() != 2 || !GRAD_TERM_API.contains(&item.as_str()) {
                    backend_grad.insert(format!("{}: crate::{}", rel.display(), path.join("::")));
                }
                continue;
            }
            match layer(&used) {
                Some(l) if l < own => {}
                Some(l) => {
                    wrong.insert(format!(
                        "{} (layer {own}) uses {used} (layer {l}): crate::{}",
                        rel.display(),
                        path.join("::")
                    ));
                }
                None => {
                    wrong.insert(format!("{}: crate::{} names no module in LAYERS", rel.display(), path.join("::")));
                }
            }
        }
    }
    assert!(wrong.is_empty(), "paths against the layers:\n{}", wrong.into_iter().collect::<Vec<_>>().join("\n"));
    assert!(
        backend_grad.is_empty(),
        "backend uses grad beyond its term API (GRAD_TERM_API):\n{}",
        backend_grad.into_iter().collect::<Vec<_>>().join("\n")
    );
}
