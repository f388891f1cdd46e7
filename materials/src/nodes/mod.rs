//! Node types and the registry that names them in graph files.

mod blur;
mod bricks;
mod cells;
mod filters;
mod noise_gen;
mod normal;
mod patterns;
mod planks;
mod resample;
mod scratches;
mod weave;
mod wood;

use crate::kernel::{GenNode, PointNode};
use crate::node_op::{Channels, InputSpec, NodeSpec, OutRule, SlotKind, SlotSpec};

const fn float(name: &'static str, min: f64, max: f64, default: f64, doc: &'static str) -> SlotSpec {
    SlotSpec { name, kind: SlotKind::Float { min, max, default }, doc }
}
const fn color(name: &'static str, default: [f64; 3], doc: &'static str) -> SlotSpec {
    SlotSpec { name, kind: SlotKind::Color { default }, doc }
}
const fn int(name: &'static str, min: i64, max: i64, default: i64, doc: &'static str) -> SlotSpec {
    SlotSpec { name, kind: SlotKind::Int { min, max, default, names: &[] }, doc }
}
const fn choice(name: &'static str, names: &'static [&'static str], default: i64, doc: &'static str) -> SlotSpec {
    SlotSpec { name, kind: SlotKind::Int { min: 0, max: names.len() as i64 - 1, default, names }, doc }
}
const SEED: SlotSpec = int("seed", 0, 1 << 31, 0, "random seed");
const fn input(name: &'static str, channels: Channels) -> InputSpec {
    InputSpec { name, channels, optional: false }
}
const ANY_IN: &[InputSpec] = &[input("input", Channels::Any)];
const GRAY_IN: &[InputSpec] = &[input("input", Channels::Gray)];
const BOARD_SLOTS_TAIL: [SlotSpec; 6] = [
    SEED,
    choice("mode", planks::BOARD_MODES, 0, "mask | random (per board) | grain"),
    int("grain_scale", 1, 64, 8, "grain ring density"),
    float("gap", 0.0, 0.3, 0.03, "half gap between boards, board widths"),
    float("bevel", 0.001, 0.5, 0.05, "edge rounding, board widths"),
    float("grain_warp", 0.0, 3.0, 0.8, "bending of the grain rings"),
];

macro_rules! gradient_stops {
    ($($k:literal $p:literal $c:expr),*) => {
        &[int("count", 2, 6, 2, "number of stops used"),
          $(float(concat!("pos", $k), 0.0, 1.0, $p, "stop position"), color(concat!("color", $k), $c, "stop colour (sRGB)")),*]
    };
}

/// Every node type, in documentation order.
pub static NODES: &[NodeSpec] = &[
    // ---- generators ----
    NodeSpec {
        name: "perlin",
        doc: "Gradient (Perlin) noise in 0..1.",
        inputs: &[],
        slots: &[int("scale_x", 1, 256, 4, "cells across"), int("scale_y", 1, 256, 4, "cells down"), SEED],
        out: OutRule::Gray,
        op: &GenNode(noise_gen::Perlin),
    },
    NodeSpec {
        name: "fbm",
        doc: "Fractal Brownian motion (clouds) in about 0..1.",
        inputs: &[],
        slots: &[
            int("scale_x", 1, 256, 4, "base cells across"),
            int("scale_y", 1, 256, 4, "base cells down"),
            int("octaves", 1, 10, 5, "octaves"),
            SEED,
            float("roughness", 0.1, 0.95, 0.5, "amplitude ratio between octaves"),
        ],
        out: OutRule::Gray,
        op: &GenNode(noise_gen::Fbm),
    },
    NodeSpec {
        name: "grunge",
        doc: "Patchy dirt mask: thresholded fBm with speckle.",
        inputs: &[],
        slots: &[
            int("scale", 1, 64, 3, "base cells"),
            SEED,
            float("threshold", 0.0, 1.0, 0.5, "coverage threshold"),
            float("softness", 0.01, 0.5, 0.1, "edge softness"),
            float("speckle", 0.0, 1.0, 0.3, "fine speckle amount"),
        ],
        out: OutRule::Gray,
        op: &GenNode(noise_gen::Grunge),
    },
    NodeSpec {
        name: "voronoi",
        doc: "Cellular noise on a jittered periodic grid: F1, F2-F1, cell edge mask, per-cell value.",
        inputs: &[],
        slots: &[
            int("scale_x", 1, 128, 8, "cells across"),
            int("scale_y", 1, 128, 8, "cells down (even when staggered)"),
            SEED,
            choice("mode", cells::VORONOI_MODES, 0, "f1 | f2_f1 | edge | cell"),
            int("stagger", 0, 1, 0, "offset odd rows by half a cell (hexagons)"),
            float("jitter", 0.0, 1.0, 1.0, "feature point randomness"),
            float("width", 0.0, 0.5, 0.05, "edge mode: mortar half-width, cell units"),
            float("softness", 0.001, 0.5, 0.05, "edge mode: bevel width, cell units"),
        ],
        out: OutRule::Gray,
        op: &GenNode(cells::Voronoi),
    },
    NodeSpec {
        name: "bricks",
        doc: "Running-bond bricks or square tiles (offset 0): mask (1 on bricks) or per-brick random value.",
        inputs: &[],
        slots: &[
            int("rows", 1, 128, 8, "rows per tile (even, so the offset tiles)"),
            int("cols", 1, 128, 4, "bricks per row"),
            SEED,
            choice("mode", bricks::TILE_MODES, 0, "mask | random"),
            float("offset", 0.0, 1.0, 0.5, "shift of odd rows, in bricks"),
            float("mortar", 0.0, 0.3, 0.04, "mortar half-width, brick heights"),
            float("bevel", 0.001, 0.5, 0.05, "edge rounding, brick heights"),
        ],
        out: OutRule::Gray,
        op: &GenNode(bricks::Bricks),
    },
    NodeSpec {
        name: "planks",
        doc: "Staggered floor boards: mask, per-board random value, or wood grain.",
        inputs: &[],
        slots: &[
            int("rows", 1, 64, 6, "boards down the tile"),
            int("per_row", 1, 16, 2, "boards across the tile"),
            BOARD_SLOTS_TAIL[0],
            BOARD_SLOTS_TAIL[1],
            BOARD_SLOTS_TAIL[2],
            BOARD_SLOTS_TAIL[3],
            BOARD_SLOTS_TAIL[4],
            BOARD_SLOTS_TAIL[5],
        ],
        out: OutRule::Gray,
        op: &GenNode(planks::Planks),
    },
    NodeSpec {
        name: "herringbone",
        doc: "Herringbone parquet: mask, per-board random value, or grain along each board.",
        inputs: &[],
        slots: &[
            int("ratio", 2, 10, 4, "board length / width"),
            int("repeat", 1, 16, 2, "pattern repeats per tile"),
            BOARD_SLOTS_TAIL[0],
            BOARD_SLOTS_TAIL[1],
            BOARD_SLOTS_TAIL[2],
            BOARD_SLOTS_TAIL[3],
            BOARD_SLOTS_TAIL[4],
            BOARD_SLOTS_TAIL[5],
        ],
        out: OutRule::Gray,
        op: &GenNode(planks::Herringbone),
    },
    NodeSpec {
        name: "stripes",
        doc: "Soft stripes; integer frequencies along u and v give straight or diagonal stripes.",
        inputs: &[],
        slots: &[
            int("freq_x", -256, 256, 0, "stripes across u"),
            int("freq_y", -256, 256, 8, "stripes across v"),
            float("width", 0.0, 1.0, 0.5, "duty cycle"),
            float("softness", 0.001, 0.5, 0.02, "edge softness, periods"),
        ],
        out: OutRule::Gray,
        op: &GenNode(patterns::Stripes),
    },
    NodeSpec {
        name: "checker",
        doc: "Checkerboard with soft edges.",
        inputs: &[],
        slots: &[
            int("count", 1, 128, 4, "periods per tile (2 cells each)"),
            float("softness", 0.001, 0.25, 0.01, "edge softness"),
        ],
        out: OutRule::Gray,
        op: &GenNode(patterns::Checker),
    },
    NodeSpec {
        name: "dots",
        doc: "Polka / shape dots on a (staggered) grid.",
        inputs: &[],
        slots: &[
            int("count", 1, 128, 8, "dots per row (even when staggered)"),
            int("stagger", 0, 1, 0, "offset odd rows"),
            choice("shape", patterns::DOT_SHAPES, 0, "circle | square | diamond"),
            SEED,
            float("radius", 0.0, 0.7, 0.3, "radius, cell units"),
            float("softness", 0.001, 0.3, 0.03, "edge softness"),
            float("size_jitter", 0.0, 1.0, 0.0, "random size reduction"),
        ],
        out: OutRule::Gray,
        op: &GenNode(patterns::Dots),
    },
    NodeSpec {
        name: "weave",
        doc: "Woven thread height (plain, twill, basket).",
        inputs: &[],
        slots: &[
            int("count", 1, 256, 16, "threads per tile"),
            choice("pattern", weave::WEAVE_PATTERNS, 0, "plain | twill | basket"),
            float("thread_width", 0.3, 1.2, 0.85, "thread width, cell units"),
            float("crimp", 0.0, 1.0, 0.4, "dip of a thread where it passes under"),
        ],
        out: OutRule::Gray,
        op: &GenNode(weave::Weave),
    },
    NodeSpec {
        name: "wood_rings",
        doc: "Wood growth rings along u, bent by noise, with fine streaks.",
        inputs: &[],
        slots: &[
            int("rings", 1, 128, 8, "rings per tile"),
            int("noise_scale", 1, 32, 2, "bending noise cells"),
            SEED,
            float("distortion", 0.0, 3.0, 0.8, "ring bending"),
            float("sharpness", 0.3, 8.0, 1.5, "ring contrast exponent"),
            float("streaks", 0.0, 1.0, 0.3, "fine streak amount"),
        ],
        out: OutRule::Gray,
        op: &GenNode(wood::WoodRings),
    },
    NodeSpec {
        name: "scratches",
        doc: "Thin random scratches (1 on a scratch).",
        inputs: &[],
        slots: &[
            int("cells", 1, 64, 6, "grid cells per tile"),
            int("per_cell", 1, 6, 2, "scratches per cell"),
            SEED,
            float("width", 0.0002, 0.02, 0.002, "line width, tile units"),
            float("length", 0.05, 1.0, 0.8, "length, cells"),
            float("spread", 0.0, 1.0, 1.0, "0 = horizontal, 1 = any direction"),
        ],
        out: OutRule::Gray,
        op: &GenNode(scratches::Scratches),
    },
    NodeSpec {
        name: "uniform",
        doc: "Constant grey value.",
        inputs: &[],
        slots: &[float("value", 0.0, 1.0, 0.5, "value")],
        out: OutRule::Gray,
        op: &PointNode(filters::Uniform),
    },
    NodeSpec {
        name: "color",
        doc: "Constant colour (sRGB).",
        inputs: &[],
        slots: &[color("color", [0.5, 0.5, 0.5], "colour")],
        out: OutRule::Color,
        op: &PointNode(filters::ConstColor),
    },
    // ---- filters ----
    NodeSpec {
        name: "blend",
        doc: "Blend b over a: normal, multiply, add, screen, overlay, subtract, lighten, darken; optional grey mask.",
        inputs: &[
            input("a", Channels::Any),
            input("b", Channels::Any),
            InputSpec { name: "mask", channels: Channels::Gray, optional: true },
        ],
        slots: &[choice("mode", filters::BLEND_MODES, 0, "blend mode"), float("opacity", 0.0, 1.0, 1.0, "opacity")],
        out: OutRule::WidestInput,
        op: &PointNode(filters::Blend),
    },
    NodeSpec {
        name: "levels",
        doc: "Input range, gamma, output range.",
        inputs: ANY_IN,
        slots: &[
            float("in_low", 0.0, 1.0, 0.0, ""),
            float("in_high", 0.0, 1.0, 1.0, ""),
            float("gamma", 0.1, 10.0, 1.0, "midtone gamma"),
            float("out_low", 0.0, 1.0, 0.0, ""),
            float("out_high", 0.0, 1.0, 1.0, ""),
        ],
        out: OutRule::WidestInput,
        op: &PointNode(filters::Levels),
    },
    NodeSpec {
        name: "curves",
        doc: "Tone curve through values at x = 0, .25, .5, .75, 1 (Catmull-Rom).",
        inputs: ANY_IN,
        slots: &[
            float("y0", -0.5, 1.5, 0.0, ""),
            float("y1", -0.5, 1.5, 0.25, ""),
            float("y2", -0.5, 1.5, 0.5, ""),
            float("y3", -0.5, 1.5, 0.75, ""),
            float("y4", -0.5, 1.5, 1.0, ""),
        ],
        out: OutRule::WidestInput,
        op: &PointNode(filters::Curves),
    },
    NodeSpec {
        name: "hsl",
        doc: "Hue rotation (turns), saturation and lightness shifts.",
        inputs: &[input("input", Channels::Color)],
        slots: &[
            float("hue", -0.5, 0.5, 0.0, "turns"),
            float("saturation", -1.0, 1.0, 0.0, ""),
            float("lightness", -1.0, 1.0, 0.0, ""),
        ],
        out: OutRule::Color,
        op: &PointNode(filters::HslShift),
    },
    NodeSpec {
        name: "gradient_map",
        doc: "Colour ramp: maps grey to colour through 2-6 stops (positions ascending).",
        inputs: GRAY_IN,
        slots: gradient_stops!("0" 0.0 [0.0, 0.0, 0.0], "1" 1.0 [1.0, 1.0, 1.0], "2" 1.0 [1.0, 1.0, 1.0],
                                "3" 1.0 [1.0, 1.0, 1.0], "4" 1.0 [1.0, 1.0, 1.0], "5" 1.0 [1.0, 1.0, 1.0]),
        out: OutRule::Color,
        op: &PointNode(filters::GradientMap),
    },
    NodeSpec {
        name: "invert",
        doc: "1 - x.",
        inputs: ANY_IN,
        slots: &[],
        out: OutRule::WidestInput,
        op: &PointNode(filters::Invert),
    },
    NodeSpec {
        name: "smooth_threshold",
        doc: "Smoothstep from threshold - softness to threshold + softness.",
        inputs: ANY_IN,
        slots: &[float("threshold", 0.0, 1.0, 0.5, ""), float("softness", 0.001, 0.5, 0.05, "")],
        out: OutRule::WidestInput,
        op: &PointNode(filters::SmoothThreshold),
    },
    NodeSpec {
        name: "clamp",
        doc: "Clamp to min..max.",
        inputs: ANY_IN,
        slots: &[float("min", 0.0, 1.0, 0.0, ""), float("max", 0.0, 1.0, 1.0, "")],
        out: OutRule::WidestInput,
        op: &PointNode(filters::Clamp),
    },
    NodeSpec {
        name: "grayscale",
        doc: "Luma of a colour.",
        inputs: ANY_IN,
        slots: &[],
        out: OutRule::Gray,
        op: &PointNode(filters::Grayscale),
    },
    NodeSpec {
        name: "blur",
        doc: "Gaussian blur with wrap-around.",
        inputs: ANY_IN,
        slots: &[float("sigma", 0.0005, 0.05, 0.005, "standard deviation, tile units")],
        out: OutRule::WidestInput,
        op: &blur::Blur,
    },
    NodeSpec {
        name: "warp",
        doc: "Directional warp: moves texels by amount * 2 (d - 0.5) along angle, d from the displacement map.",
        inputs: &[input("input", Channels::Any), input("displacement", Channels::Gray)],
        slots: &[float("amount", 0.0, 0.25, 0.02, "tile units"), float("angle", -1.0, 1.0, 0.0, "turns")],
        out: OutRule::WidestInput,
        op: &resample::Warp,
    },
    NodeSpec {
        name: "transform",
        doc: "Scale (repeats), rotate (turns), offset (tile units) with wrap; integer scales and quarter turns tile.",
        inputs: ANY_IN,
        slots: &[
            float("scale", 0.25, 8.0, 1.0, "repeats"),
            float("rotation", -0.5, 0.5, 0.0, "turns"),
            float("offset_x", -1.0, 1.0, 0.0, ""),
            float("offset_y", -1.0, 1.0, 0.0, ""),
        ],
        out: OutRule::WidestInput,
        op: &resample::Transform,
    },
    NodeSpec {
        name: "normal_from_height",
        doc: "Tangent-space normal (OpenGL, +y up the image) from a height map.",
        inputs: GRAY_IN,
        slots: &[float("strength", 0.0, 0.5, 0.02, "tile units of relief per unit height")],
        out: OutRule::Color,
        op: &normal::NormalFromHeight,
    },
];

/// Looks up a node type by name.
pub fn node_spec(name: &str) -> Option<&'static NodeSpec> {
    NODES.iter().find(|s| s.name == name)
}

/// A Markdown reference of every node type (inputs, parameters with ranges),
/// as pasted into `materials/README.md`.
pub fn reference_markdown() -> String {
    use std::fmt::Write;
    let mut s = String::new();
    for spec in NODES {
        let _ = writeln!(s, "### `{}`\n{}\n", spec.name, spec.doc);
        if !spec.inputs.is_empty() {
            let ins: Vec<String> = spec
                .inputs
                .iter()
                .map(|i| {
                    let ch = match i.channels {
                        Channels::Gray => "grey",
                        Channels::Color => "colour",
                        Channels::Any => "grey or colour",
                    };
                    format!("`{}` ({ch}{})", i.name, if i.optional { ", optional" } else { "" })
                })
                .collect();
            let _ = writeln!(s, "Inputs: {}.\n", ins.join(", "));
        }
        if !spec.slots.is_empty() {
            let _ = writeln!(s, "| parameter | kind | range | default | meaning |\n|---|---|---|---|---|");
            for slot in spec.slots {
                let (kind, range, default) = match slot.kind {
                    SlotKind::Float { min, max, default } => ("float", format!("{min} .. {max}"), format!("{default}")),
                    SlotKind::Color { default } => ("color", "0 .. 1 each".into(), format!("{default:?}")),
                    SlotKind::Int { min, max, default, names: [] } => {
                        ("int", format!("{min} .. {max}"), format!("{default}"))
                    }
                    SlotKind::Int { default, names, .. } => {
                        ("choice", names.join(" \\| "), names[default as usize].to_string())
                    }
                };
                let _ = writeln!(s, "| `{}` | {kind} | {range} | {default} | {} |", slot.name, slot.doc);
            }
            s.push('\n');
        }
    }
    s
}
