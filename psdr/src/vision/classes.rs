//! psdr's object classes and the synonyms segmentation tools use for them (ADE20K, COCO, free text). The
//! room stage reads the structural classes; every other class is furniture to retrieve, and a class psdr does
//! not know is kept as `object`.

/// What a class is for the pipeline.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ClassKind {
    /// floor, wall, ceiling: the room box.
    Structure,
    /// window, door: openings in the walls (lights and constraints later), not retrieved as furniture.
    Opening,
    /// Everything that becomes a retrieved model.
    Furniture,
}

/// (canonical class, kind, synonyms). Matching is case-insensitive on the whole name, after trimming and
/// turning '_' and '-' into spaces.
const CLASSES: &[(&str, ClassKind, &[&str])] = &[
    ("floor", ClassKind::Structure, &["floor", "flooring", "ground", "parquet", "floor other"]),
    ("wall", ClassKind::Structure, &["wall", "walls", "wall other", "partition"]),
    ("ceiling", ClassKind::Structure, &["ceiling", "roof"]),
    ("window", ClassKind::Opening, &["window", "windowpane", "window pane", "skylight"]),
    ("door", ClassKind::Opening, &["door", "doorway", "double door", "screen door"]),
    (
        "lamp",
        ClassKind::Furniture,
        &["lamp", "light", "chandelier", "sconce", "floor lamp", "table lamp", "ceiling light"],
    ),
    ("sofa", ClassKind::Furniture, &["sofa", "couch", "settee", "loveseat", "sectional"]),
    ("armchair", ClassKind::Furniture, &["armchair", "arm chair", "easy chair", "recliner"]),
    ("chair", ClassKind::Furniture, &["chair", "swivel chair", "office chair", "dining chair", "stool", "seat"]),
    (
        "table",
        ClassKind::Furniture,
        &["table", "coffee table", "dining table", "side table", "end table", "kitchen island"],
    ),
    ("desk", ClassKind::Furniture, &["desk", "writing desk", "computer desk"]),
    ("bed", ClassKind::Furniture, &["bed", "double bed", "single bed", "cradle", "crib"]),
    (
        "cabinet",
        ClassKind::Furniture,
        &[
            "cabinet",
            "chest of drawers",
            "dresser",
            "sideboard",
            "cupboard",
            "drawer",
            "nightstand",
            "night stand",
            "buffet",
        ],
    ),
    ("shelf", ClassKind::Furniture, &["shelf", "shelves", "wall shelf"]),
    ("bookcase", ClassKind::Furniture, &["bookcase", "bookshelf", "book shelf"]),
    ("wardrobe", ClassKind::Furniture, &["wardrobe", "closet", "armoire", "press"]),
    ("plant", ClassKind::Furniture, &["plant", "potted plant", "flower", "flowerpot", "pot", "vase"]),
    ("bin", ClassKind::Furniture, &["bin", "trash can", "wastebasket", "ashcan", "garbage can"]),
    ("tv", ClassKind::Furniture, &["tv", "television", "television receiver", "monitor", "screen", "crt screen"]),
    ("rug", ClassKind::Furniture, &["rug", "carpet", "mat"]),
    ("mirror", ClassKind::Furniture, &["mirror"]),
    ("picture", ClassKind::Furniture, &["picture", "painting", "poster", "frame", "photo"]),
    ("curtain", ClassKind::Furniture, &["curtain", "drape", "drapery", "blind", "shade"]),
    ("cushion", ClassKind::Furniture, &["cushion", "pillow"]),
];

/// The class of an unknown name.
pub const UNKNOWN_CLASS: &str = "object";

/// The canonical psdr class of a label and its kind; unknown labels are `object`, furniture. Segmenters' own
/// spellings are understood: COCO-panoptic's qualifiers (`wall-other-merged`, `door-stuff`) are dropped, and
/// its `CLASS-MATERIAL` names (`floor-wood`, `wall-brick`) are their class.
pub fn canonical_class(label: &str) -> (&'static str, ClassKind) {
    let norm: String =
        label.trim().to_lowercase().chars().map(|c| if c == '_' || c == '-' { ' ' } else { c }).collect();
    let words: Vec<&str> = norm.split_whitespace().collect();
    let find = |name: &str| CLASSES.iter().find(|(c, _, syn)| *c == name || syn.contains(&name));
    let plain: Vec<&str> = words.iter().copied().filter(|w| !["merged", "other", "stuff"].contains(w)).collect();
    let hyphenated = label.contains('-');
    find(&words.join(" "))
        .or_else(|| find(&plain.join(" ")))
        .or_else(|| plain.first().filter(|_| hyphenated).and_then(|w| find(w)))
        .map_or((UNKNOWN_CLASS, ClassKind::Furniture), |(name, kind, _)| (*name, *kind))
}

/// Every canonical class, for messages and documentation.
pub fn class_names() -> Vec<&'static str> {
    CLASSES.iter().map(|c| c.0).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn synonyms_map_to_canonical_classes() {
        assert_eq!(canonical_class("Couch"), ("sofa", ClassKind::Furniture));
        assert_eq!(canonical_class(" windowpane "), ("window", ClassKind::Opening));
        assert_eq!(canonical_class("chest_of-drawers"), ("cabinet", ClassKind::Furniture));
        assert_eq!(canonical_class("floor"), ("floor", ClassKind::Structure));
        assert_eq!(canonical_class("potted plant"), ("plant", ClassKind::Furniture));
        assert_eq!(canonical_class("spaceship"), ("object", ClassKind::Furniture));
        // COCO-panoptic and ADE20K names as segmenters emit them.
        for (label, class) in [
            ("floor-wood", "floor"),
            ("wall-other-merged", "wall"),
            ("wall-brick", "wall"),
            ("window-other", "window"),
            ("ceiling-merged", "ceiling"),
            ("door-stuff", "door"),
            ("rug-merged", "rug"),
            ("table-merged", "table"),
            ("potted plant", "plant"),
            ("chest of drawers", "cabinet"),
        ] {
            assert_eq!(canonical_class(label).0, class, "{label}");
        }
        // Only a hyphenated name falls back to its first word: free text "table tennis" is not a table.
        assert_eq!(canonical_class("table tennis").0, "object");
        // Every synonym maps to its own class (no synonym listed under two classes).
        for (name, _, syn) in CLASSES {
            for s in syn.iter() {
                assert_eq!(canonical_class(s).0, *name, "{s}");
            }
        }
    }
}
