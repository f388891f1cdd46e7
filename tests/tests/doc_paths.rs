//! Every relative path the documentation and the code's comments name exists in the repository, and nothing
//! cites a file outside it: Markdown links (`[x](docs/pipeline.md)`, resolved against the Markdown file) and
//! repository paths written in text or comments (`psdr/src/grad/boundary/shadow.rs`, resolved against the
//! repository's root) in every tracked Markdown, Rust, GLSL, Rhai, shell, Python and TOML file. A renamed or
//! removed file that a page still names fails here.

use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..").canonicalize().unwrap()
}

/// The repository's text files, skipping build output and hidden folders.
fn files(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap().flatten() {
        let p = e.path();
        let name = e.file_name().to_string_lossy().into_owned();
        if name.starts_with('.') || name == "target" || name == "node_modules" {
            continue;
        }
        if p.is_dir() {
            files(&p, out);
        } else if ["md", "rs", "glsl", "comp", "rhai", "sh", "py", "toml"]
            .iter()
            .any(|x| p.extension().is_some_and(|e| e == *x))
        {
            out.push(p);
        }
    }
}

/// Top folders whose paths a text may name.
const TOP: [&str; 10] =
    ["psdr/", "vk/", "materials/", "shaders/", "scripts/", "tests/", "benchmarks/", "examples/", "docs/", ".ci/"];
const EXTENSIONS: [&str; 16] =
    ["rs", "glsl", "comp", "md", "rhai", "json", "py", "sh", "png", "obj", "mtl", "csv", "svg", "toml", "exr", "onnx"];

/// Repository paths in a text: a top folder, then path characters, ending in a known extension.
fn repo_paths(text: &str) -> Vec<String> {
    let mut out = vec![];
    let is_path = |c: char| c.is_ascii_alphanumeric() || "_-./".contains(c);
    for top in TOP {
        let mut from = 0;
        while let Some(i) = text[from..].find(top).map(|i| i + from) {
            from = i + top.len();
            // The path must start the token (not "../psdr/" or "target/psdr/").
            if i > 0 && text[..i].chars().next_back().is_some_and(&is_path) {
                continue;
            }
            let end = text[i..].find(|c: char| !is_path(c)).map_or(text.len(), |e| i + e);
            let p = text[i..end].trim_end_matches(['.', '/']);
            // Placeholders (NAME, NN) name a pattern, not a file.
            let placeholder = p.contains("NN") || p.contains("NAME") || p.contains('*');
            if EXTENSIONS.iter().any(|x| p.ends_with(&format!(".{x}"))) && !placeholder {
                out.push(p.to_string());
            }
        }
    }
    out
}

/// Relative Markdown link targets: `](target)` that are not URLs or anchors.
fn markdown_links(text: &str) -> Vec<String> {
    let mut out = vec![];
    let mut from = 0;
    while let Some(i) = text[from..].find("](").map(|i| i + from) {
        from = i + 2;
        let Some(end) = text[from..].find(')') else { break };
        let target = text[from..from + end].split('#').next().unwrap_or("").trim().to_string();
        if !target.is_empty() && !target.contains("://") && !target.starts_with("mailto:") {
            out.push(target);
        }
    }
    out
}

/// Citations of files outside the repository: an upper-case Markdown name (`NOTES.md`) that no file in the
/// repository has, and a `../` path that climbs out of it from every folder it may be read from.
/// `bases` are the folders the text's relative paths may be read from (its own, its crate's), relative to the root.
fn outside_citations(text: &str, names: &std::collections::HashSet<String>, bases: &[PathBuf]) -> Vec<String> {
    let is_name = |c: char| c.is_ascii_alphanumeric() || c == '_' || c == '-';
    let mut out = vec![];
    let mut from = 0;
    while let Some(i) = text[from..].find(".md").map(|i| i + from) {
        from = i + 3;
        let start = text[..i].rfind(|c: char| !is_name(c)).map_or(0, |s| s + 1);
        let stem = &text[start..i];
        let upper = stem.len() > 1 && stem.chars().all(|c| c.is_ascii_uppercase() || c == '_' || c == '-');
        let name = format!("{stem}.md");
        if upper && !names.contains(&name) && !stem.contains("NAME") {
            out.push(name);
        }
    }
    for (i, _) in text.match_indices("../") {
        // Only a path that starts at a token's start climbs from where the text is read, not `a/../b`.
        if i > 0 && text[..i].chars().next_back().is_some_and(|c| c.is_ascii_alphanumeric() || "_-./".contains(c)) {
            continue;
        }
        let end =
            text[i..].find(|c: char| !(c.is_ascii_alphanumeric() || "_-./".contains(c))).map_or(text.len(), |e| i + e);
        let p = &text[i..end];
        if !bases.iter().any(|b| inside(b, p)) {
            out.push(p.to_string());
        }
    }
    out
}

/// Whether `rel`, read from `base` (a folder relative to the repository's root), stays inside the repository.
fn inside(base: &Path, rel: &str) -> bool {
    let mut depth = base.components().count() as i64;
    for part in rel.split('/') {
        match part {
            ".." => depth -= 1,
            "" | "." => {}
            _ => depth += 1,
        }
        if depth < 0 {
            return false;
        }
    }
    true
}

#[test]
fn every_path_the_docs_and_comments_name_exists() {
    let root = root();
    let mut all = vec![];
    files(&root, &mut all);
    assert!(all.len() > 200, "found only {} files under {}", all.len(), root.display());
    let names: std::collections::HashSet<String> =
        all.iter().filter_map(|f| f.file_name().map(|n| n.to_string_lossy().into_owned())).collect();
    let mut missing = vec![];
    let mut checked = 0;
    for f in &all {
        let Ok(text) = std::fs::read_to_string(f) else { continue };
        let rel = f.strip_prefix(&root).unwrap_or(f).display().to_string();
        if rel == "tests/tests/doc_paths.rs" {
            continue; // its own examples
        }
        // A path may be written from the repository's root, from the file's crate, or from the file's folder.
        let crate_dir = f.ancestors().skip(1).find(|d| d.join("Cargo.toml").is_file()).unwrap_or(&root).to_path_buf();
        let exists =
            |p: &str| [&root, &crate_dir, &f.parent().unwrap().to_path_buf()].iter().any(|d| d.join(p).exists());
        let bases: Vec<PathBuf> = [crate_dir.as_path(), f.parent().unwrap()]
            .iter()
            .map(|d| d.strip_prefix(&root).unwrap_or(Path::new("")).to_path_buf())
            .collect();
        for o in outside_citations(&text, &names, &bases) {
            missing.push(format!("{rel}: cites {o}, a file outside the repository"));
        }
        for p in repo_paths(&text) {
            checked += 1;
            if !exists(&p) {
                missing.push(format!("{rel}: names {p}"));
            }
        }
        if f.extension().is_some_and(|e| e == "md") {
            for l in markdown_links(&text) {
                checked += 1;
                if !f.parent().unwrap().join(&l).exists() {
                    missing.push(format!("{rel}: links {l}"));
                }
            }
        }
    }
    assert!(checked > 100, "only {checked} paths checked: the scanner is broken");
    assert!(missing.is_empty(), "{} missing:\n{}", missing.len(), missing.join("\n"));
}

#[test]
fn the_scanner_finds_paths_and_links() {
    let text =
        "see psdr/src/grad/boundary/shadow.rs, `docs/pipeline.md`. Not ../psdr/x.rs nor stages/NN_x/scene.json; \
                [a](docs/a.md#b) [web](https://x.org/y.md)";
    assert_eq!(repo_paths(text), vec!["psdr/src/grad/boundary/shadow.rs", "docs/pipeline.md", "docs/a.md"]);
    assert_eq!(markdown_links(text), vec!["docs/a.md"]);
    let names = ["README.md".to_string()].into_iter().collect();
    let cites = "see README.md and NOTES.md, ../elsewhere/x.txt, not a/../b nor docs/NAME.md";
    assert_eq!(outside_citations(cites, &names, &[PathBuf::new()]), vec!["NOTES.md", "../elsewhere/x.txt"]);
    // From a crate's folder, `../README.md` is the root's; `../../x` is outside.
    assert_eq!(outside_citations("../README.md ../../x", &names, &[PathBuf::from("psdr")]), vec!["../../x"]);
}
