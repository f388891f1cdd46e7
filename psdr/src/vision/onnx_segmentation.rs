//! Segmentation from an ONNX model (`segmentation.onnx` in the models folder), ADE20K's 150 classes. Output
//! contract: the first output, either float32 logits `[1, 150, h, w]` (argmax per pixel) or int64 class indices
//! `[1, h, w]` / `[1, 1, h, w]`, 0-based in ADE20K-150's order (SceneParsing `objectInfo150`: 0 wall, 3 floor,
//! 5 ceiling, ...). Classes map to psdr's by name (`classes`: windowpane -> window, chest of drawers ->
//! cabinet, ...; unknown names stay `object`). The class map is upsampled to the photo (nearest); the floor,
//! the walls and the ceiling become one instance each, every other class one instance per connected region
//! (4-neighbours), regions under 0.1 % of the image dropped.
//!
//! Exporting a public model: SegFormer-B0 fine-tuned on ADE20K (`nvidia/segformer-b0-finetuned-ade-512-512`)
//! with `torch.onnx.export(model, torch.randn(1, 3, 512, 512), "segmentation.onnx", input_names=["image"],
//! output_names=["logits"], opset_version=17)`; its normalisation is this contract's.

use super::classes::{canonical_class, ClassKind};
use super::masks::{Instance, Instances};
use super::onnx_model::OnnxModel;
use crate::base::Image;
use crate::error::{Error, Result};

/// ADE20K-150 class names, 0-based.
pub const ADE20K_CLASSES: [&str; 150] = [
    "wall",
    "building",
    "sky",
    "floor",
    "tree",
    "ceiling",
    "road",
    "bed",
    "windowpane",
    "grass",
    "cabinet",
    "sidewalk",
    "person",
    "earth",
    "door",
    "table",
    "mountain",
    "plant",
    "curtain",
    "chair",
    "car",
    "water",
    "painting",
    "sofa",
    "shelf",
    "house",
    "sea",
    "mirror",
    "rug",
    "field",
    "armchair",
    "seat",
    "fence",
    "desk",
    "rock",
    "wardrobe",
    "lamp",
    "bathtub",
    "railing",
    "cushion",
    "base",
    "box",
    "column",
    "signboard",
    "chest of drawers",
    "counter",
    "sand",
    "sink",
    "skyscraper",
    "fireplace",
    "refrigerator",
    "grandstand",
    "path",
    "stairs",
    "runway",
    "case",
    "pool table",
    "pillow",
    "screen door",
    "stairway",
    "river",
    "bridge",
    "bookcase",
    "blind",
    "coffee table",
    "toilet",
    "flower",
    "book",
    "hill",
    "bench",
    "countertop",
    "stove",
    "palm",
    "kitchen island",
    "computer",
    "swivel chair",
    "boat",
    "bar",
    "arcade machine",
    "hovel",
    "bus",
    "towel",
    "light",
    "truck",
    "tower",
    "chandelier",
    "awning",
    "streetlight",
    "booth",
    "television receiver",
    "airplane",
    "dirt track",
    "apparel",
    "pole",
    "land",
    "bannister",
    "escalator",
    "ottoman",
    "bottle",
    "buffet",
    "poster",
    "stage",
    "van",
    "ship",
    "fountain",
    "conveyer belt",
    "canopy",
    "washer",
    "plaything",
    "swimming pool",
    "stool",
    "barrel",
    "basket",
    "waterfall",
    "tent",
    "bag",
    "minibike",
    "cradle",
    "oven",
    "ball",
    "food",
    "step",
    "tank",
    "trade name",
    "microwave",
    "pot",
    "animal",
    "bicycle",
    "lake",
    "dishwasher",
    "screen",
    "blanket",
    "sculpture",
    "hood",
    "sconce",
    "vase",
    "traffic light",
    "tray",
    "ashcan",
    "fan",
    "pier",
    "crt screen",
    "plate",
    "monitor",
    "bulletin board",
    "shower",
    "radiator",
    "glass",
    "clock",
    "flag",
];

/// The per-pixel ADE20K class at the photo's size.
fn class_map(model: &mut OnnxModel, photo: &Image) -> Result<Vec<usize>> {
    let out = model.run(photo)?;
    let (c, h, w) = match out.shape.as_slice() {
        [1, c, h, w] if !out.integer && *c == ADE20K_CLASSES.len() => (*c, *h, *w),
        [1, h, w] | [1, 1, h, w] if out.integer => (1, *h, *w),
        s => {
            return Err(Error::io(
                &model.path,
                format!(
                    "a segmentation model's output must be float32 logits [1, 150, h, w] or int64 ADE20K indices \
                     [1, h, w], not {} {s:?}",
                    if out.integer { "int64" } else { "float32" }
                ),
            ))
        }
    };
    let at_model: Vec<usize> = (0..h * w)
        .map(|p| {
            if c == 1 {
                return out.data[p] as usize;
            }
            (0..c)
                .max_by(|&a, &b| out.data[a * h * w + p].total_cmp(&out.data[b * h * w + p]).then(b.cmp(&a)))
                .unwrap_or(0)
        })
        .collect();
    if let Some(bad) = at_model.iter().find(|&&k| k >= ADE20K_CLASSES.len()) {
        return Err(Error::io(&model.path, format!("class index {bad} is outside ADE20K's 150 classes")));
    }
    let (pw, ph) = (photo.width, photo.height);
    Ok((0..pw * ph)
        .map(|p| {
            let (x, y) = (p % pw, p / pw);
            let (mx, my) = (
                ((x as f32 + 0.5) * w as f32 / pw as f32) as usize,
                ((y as f32 + 0.5) * h as f32 / ph as f32) as usize,
            );
            at_model[my.min(h - 1) * w + mx.min(w - 1)]
        })
        .collect())
}

/// Instances from the model's classes, by the rules in the module's documentation.
pub fn estimate_instances(model: &mut OnnxModel, photo: &Image) -> Result<Instances> {
    let classes = class_map(model, photo)?;
    let (w, h) = (photo.width, photo.height);
    let min_pixels = (w * h / 1000).max(16);
    let mut ids = vec![0u16; w * h];
    let mut instances: Vec<Instance> = vec![];
    let mut structure_ids: Vec<(usize, u16)> = vec![];
    // The 4-connected regions of each class.
    for region in crate::base::connected_regions(&classes, w) {
        let k = classes[region[0]];
        let (class, kind) = canonical_class(ADE20K_CLASSES[k]);
        let new_instance = |instances: &mut Vec<Instance>| {
            let id = instances.len() as u16 + 1;
            instances.push(Instance {
                id,
                label: Some(ADE20K_CLASSES[k].into()),
                class: class.into(),
                kind,
                pixels: 0,
            });
            id
        };
        let id = if kind == ClassKind::Structure {
            match structure_ids.iter().find(|(c, _)| *c == k) {
                Some(&(_, id)) => id,
                None => {
                    let id = new_instance(&mut instances);
                    structure_ids.push((k, id));
                    id
                }
            }
        } else if region.len() >= min_pixels && instances.len() < u16::MAX as usize - 1 {
            new_instance(&mut instances)
        } else {
            0
        };
        for &p in &region {
            ids[p] = id;
        }
        if id != 0 {
            instances[id as usize - 1].pixels += region.len();
        }
    }
    if instances.is_empty() {
        return Err(Error::io(&model.path, "the segmentation holds no region large enough to be an instance"));
    }
    Ok(Instances { width: w, height: h, ids, instances })
}
