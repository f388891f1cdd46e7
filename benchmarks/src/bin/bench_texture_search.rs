//! How well the weight-free material search (`psdr::stages::search_materials_on`: texture descriptor, mean
//! colour, fineness, contrast; scale and rotation search) recognises the library's own materials (issue
//! "Appearance", item 4):
//! `cargo run -p psdr-benchmarks --release --bin bench_texture_search [-- --extra 4 --threads 2]`.
//!
//! Every library material (albedo at default parameters, 128x128 texels: the pipeline's `library_size`) is
//! seen through query variants (uv scale, rotation, a light gain with a colour cast that the albedo division
//! did not remove, photo noise): by default `base` for every material and one of the other four in turn (a
//! query costs ~17 s of one core; `--extra 4` runs all five on every material). A query is a 64x64 crop (the pipeline's `max_crop`) of a surface
//! facing the camera, uv 0..1 across it, rendered through `view_at` with 4x4 samples per pixel (a camera's
//! pixel footprint); it is searched as the pipeline's `texture_surfaces` searches a crop: `search_materials_with`
//! (no encoder) over a uv grid of 3x3 samples per pixel, top_k 3, colour weight 1. The search keeps only its
//! top 3, so the true material's rank is known to 3.
//!
//! Writes `benchmarks/results/texture_search.csv` (one row per query), `texture_search_confusion.csv` (true
//! family x top-1 family, family = the graph's `category`, plus a wood / not-wood block) and
//! `texture_search.svg` (top-1 and top-3 accuracy per family and per variant).

use psdr::stages::{contrast, library_textures, search_materials_with};
use psdr_materials::library;
use psdr_tests::texture_queries::{facing_grid, query, Variant, VARIANTS, WOOD};
use psdr_tests::SplitMix64;
use std::collections::BTreeMap;
use std::time::Instant;

/// Top-1 / top-3 accuracy of the search on every library material under varied scale, rotation and light.
#[derive(clap::Parser)]
struct Args {
    /// Output CSV (the confusion CSV and the SVG go next to it).
    #[arg(default_value_os_t = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("results/texture_search.csv"))]
    out: std::path::PathBuf,
    /// Comma-separated variants (base, rot30, dim_warm, bright_cool, fine_rot90, coarse, mixed); the first is
    /// run on every material, the others round-robin (see `--extra`).
    #[arg(long, value_delimiter = ',', default_value = "base,rot30,dim_warm,bright_cool,fine_rot90")]
    variants: Vec<String>,
    /// How many of the other variants each material gets besides the first, in turn (material i starts at the
    /// (i mod n)-th): a query takes ~17 s on one core, so every variant on every material would take an hour.
    #[arg(long, default_value_t = 1)]
    extra: usize,
    /// Worker threads (each runs whole queries; the search itself is single-threaded).
    #[arg(long, default_value_t = 2)]
    threads: usize,
    /// Samples per pixel side of the search's uv grid (the pipeline's `samples`, 3).
    #[arg(long, default_value_t = 3)]
    samples: usize,
    /// Crop size in pixels (the pipeline's `max_crop`, 64).
    #[arg(long, default_value_t = 64)]
    crop: usize,
    /// Only the first N library materials (0: all).
    #[arg(long, default_value_t = 0)]
    limit: usize,
    /// Seed of the photo noise.
    #[arg(long, default_value_t = 7)]
    seed: u64,
}

struct Row {
    material: String,
    family: String,
    variant: &'static str,
    top: Vec<String>,
    rank: Option<usize>,
    top1_scale: f32,
    top1_rotation: f32,
    contrast: f32,
    seconds: f64,
}

fn pct(n: usize, d: usize) -> f64 {
    if d == 0 {
        0.0
    } else {
        100.0 * n as f64 / d as f64
    }
}

fn main() -> anyhow::Result<()> {
    let args = <Args as clap::Parser>::parse();
    let mut variants: Vec<&Variant> = vec![];
    for name in &args.variants {
        let v = VARIANTS.iter().find(|v| v.name == name.as_str());
        variants.push(v.ok_or_else(|| anyhow::anyhow!("no variant '{name}'"))?);
    }
    anyhow::ensure!(!variants.is_empty(), "no variants");
    let t = Instant::now();
    let lib = library_textures(128)?;
    println!("{} library textures in {:.1} s", lib.len(), t.elapsed().as_secs_f64());
    let mut family: BTreeMap<String, String> = BTreeMap::new();
    for name in library::names() {
        let g = library::load(name).expect("listed")?;
        family.insert(name.to_string(), g.category.clone());
    }
    let fam = |n: &str| family.get(n).cloned().unwrap_or_default();
    let is_wood = |n: &str| WOOD.contains(&n);
    let camera = facing_grid(args.crop, 4);
    let search_grid = facing_grid(args.crop, args.samples);
    let n = if args.limit == 0 { lib.len() } else { args.limit.min(lib.len()) };
    // The plan: (material, variant) pairs.
    let others = variants.len() - 1;
    let mut jobs: Vec<(usize, usize)> = vec![];
    for i in 0..n {
        jobs.push((i, 0));
        for k in 0..args.extra.min(others) {
            jobs.push((i, 1 + (i + k) % others));
        }
    }
    println!("{} queries ({} materials), {} threads", jobs.len(), n, args.threads.max(1));
    let next = std::sync::atomic::AtomicUsize::new(0);
    let results = std::sync::Mutex::new(Vec::<(usize, Row)>::new());
    let run = || -> anyhow::Result<()> {
        loop {
            let j = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            let Some(&(i, vi)) = jobs.get(j) else { return Ok(()) };
            let (tex, v) = (&lib[i], variants[vi]);
            // Noise seeded per query: the same crops whatever the threads.
            let mut rng = SplitMix64(args.seed ^ ((i as u64) << 32) ^ (vi as u64 + 1).wrapping_mul(0x9E37_79B9));
            let crop = query(tex, v, &camera, &mut rng);
            let s = Instant::now();
            let top = search_materials_with(&crop, &search_grid, &lib, 3, 1.0, None)?;
            let seconds = s.elapsed().as_secs_f64();
            let names: Vec<String> = top.iter().map(|m| m.name.clone()).collect();
            let rank = names.iter().position(|m| *m == tex.name).map(|k| k + 1);
            println!(
                "{:>3}/{} {:<20} {:<11} {:<48} rank {:<2} {seconds:5.2} s",
                j + 1,
                jobs.len(),
                tex.name,
                v.name,
                names.join(" "),
                rank.map_or("-".into(), |r| r.to_string())
            );
            let row = Row {
                material: tex.name.clone(),
                family: fam(&tex.name),
                variant: v.name,
                top1_scale: top.first().map_or(f32::NAN, |m| m.scale),
                top1_rotation: top.first().map_or(f32::NAN, |m| m.rotation_deg),
                top: names,
                rank,
                contrast: contrast(&crop),
                seconds,
            };
            results.lock().expect("no worker panicked").push((j, row));
        }
    };
    let wall = Instant::now();
    std::thread::scope(|sc| {
        let handles: Vec<_> = (0..args.threads.max(1)).map(|_| sc.spawn(run)).collect();
        handles.into_iter().try_for_each(|h| h.join().expect("a worker panicked"))
    })?;
    let wall = wall.elapsed().as_secs_f64();
    let mut rows = results.into_inner().expect("no worker panicked");
    rows.sort_by_key(|(j, _)| *j);
    let rows: Vec<Row> = rows.into_iter().map(|(_, r)| r).collect();

    // Per-query CSV.
    let mut csv = String::from(
        "material,family,wood,variant,scale,rotation_deg,gain_r,gain_g,gain_b,noise,crop_contrast,top1,top2,top3,\
         rank,top1_family,top1_scale,top1_rotation_deg,seconds\n",
    );
    for r in &rows {
        let v = variants.iter().find(|v| v.name == r.variant).expect("a variant");
        let t = |k: usize| r.top.get(k).cloned().unwrap_or_default();
        csv += &format!(
            "{},{},{},{},{},{},{},{},{},{},{:.4},{},{},{},{},{},{:.4},{},{:.3}\n",
            r.material,
            r.family,
            is_wood(&r.material),
            r.variant,
            v.scale,
            v.rotation_deg,
            v.gain[0],
            v.gain[1],
            v.gain[2],
            v.noise,
            r.contrast,
            t(0),
            t(1),
            t(2),
            r.rank.map_or(String::new(), |k| k.to_string()),
            fam(&t(0)),
            r.top1_scale,
            r.top1_rotation,
            r.seconds
        );
    }

    // Summaries.
    let top1 = |r: &Row| r.rank == Some(1);
    let top3 = |r: &Row| r.rank.is_some();
    let count = |f: &dyn Fn(&Row) -> bool, sel: &dyn Fn(&Row) -> bool| {
        let s: Vec<&Row> = rows.iter().filter(|r| sel(r)).collect();
        (s.iter().filter(|r| f(r)).count(), s.len())
    };
    let (a1, n_all) = count(&top1, &|_| true);
    let (a3, _) = count(&top3, &|_| true);
    let secs: Vec<f64> = rows.iter().map(|r| r.seconds).collect();
    let mean_s = secs.iter().sum::<f64>() / secs.len().max(1) as f64;
    let max_s = secs.iter().cloned().fold(0.0, f64::max);
    println!(
        "\noverall: top-1 {a1}/{n_all} ({:.1} %), top-3 {a3}/{n_all} ({:.1} %); {mean_s:.2} s per query (max {max_s:.2}), \
         {wall:.0} s wall on {} threads",
        pct(a1, n_all),
        pct(a3, n_all),
        args.threads.max(1)
    );
    let (f1, _) = count(&|r: &Row| fam(&r.top[0]) == r.family, &|_| true);
    println!("top-1 in the true family: {f1}/{n_all} ({:.1} %)", pct(f1, n_all));
    let families: Vec<String> = {
        let mut f: Vec<String> = family.values().cloned().collect();
        f.sort();
        f.dedup();
        f
    };
    let mut fam_bars = vec![];
    println!("\nper family (category): top-1, top-3, top-1 in the family");
    for f in &families {
        let sel = |r: &Row| r.family == *f;
        let (t1, nf) = count(&top1, &sel);
        let (t3, _) = count(&top3, &sel);
        let (tf, _) = count(&|r: &Row| fam(&r.top[0]) == r.family, &sel);
        println!(
            "  {f:<10} n {nf:>3}  top-1 {:5.1} %  top-3 {:5.1} %  family {:5.1} %",
            pct(t1, nf),
            pct(t3, nf),
            pct(tf, nf)
        );
        fam_bars.push((format!("{f} ({nf})"), vec![pct(t1, nf), pct(t3, nf), pct(tf, nf)]));
    }
    let mut var_bars = vec![];
    println!("\nper variant: top-1, top-3");
    for v in &variants {
        let sel = |r: &Row| r.variant == v.name;
        let (t1, nv) = count(&top1, &sel);
        let (t3, _) = count(&top3, &sel);
        if nv == 0 {
            continue;
        }
        println!("  {:<11} n {nv:>3}  top-1 {:5.1} %  top-3 {:5.1} %", v.name, pct(t1, nv), pct(t3, nv));
        var_bars.push((format!("variant {} ({nv})", v.name), vec![pct(t1, nv), pct(t3, nv), f64::NAN]));
    }
    // Crops the pipeline would search (its gate is local contrast >= 0.08; the global contrast stands in here).
    let textured = |r: &Row| r.contrast >= 0.08;
    let (tt1, nt) = count(&top1, &textured);
    let (tt3, _) = count(&top3, &textured);
    println!(
        "\ncrops with contrast >= 0.08: top-1 {tt1}/{nt} ({:.1} %), top-3 {tt3}/{nt} ({:.1} %)",
        pct(tt1, nt),
        pct(tt3, nt)
    );
    println!("\nper material: top-1 and top-3 of its queries, and the misses (variant->top-1)");
    for tex in &lib[..n] {
        let sel = |r: &Row| r.material == tex.name;
        let (t1, nm) = count(&top1, &sel);
        let (t3, _) = count(&top3, &sel);
        let wrong: Vec<String> =
            rows.iter().filter(|r| sel(r) && !top1(r)).map(|r| format!("{}->{}", r.variant, r.top[0])).collect();
        println!("  {:<20} {t1}/{nm} {t3}/{nm}  {}", tex.name, wrong.join(" "));
    }

    // Wood.
    let wood_rows: Vec<&Row> = rows.iter().filter(|r| is_wood(&r.material)).collect();
    let wood_out: Vec<&&Row> = wood_rows.iter().filter(|r| !is_wood(&r.top[0])).collect();
    println!("\nwood crops matched (top-1) to a non-wood material: {}/{}", wood_out.len(), wood_rows.len());
    for r in &wood_out {
        println!("  {} {} -> {} ({})", r.material, r.variant, r.top[0], fam(&r.top[0]));
    }
    let non_wood_in = rows.iter().filter(|r| !is_wood(&r.material) && is_wood(&r.top[0])).count();
    println!("non-wood crops matched to a wood material: {non_wood_in}/{}", rows.len() - wood_rows.len());

    // Confusion: true family x top-1 family, then wood x wood.
    let mut conf = String::from("true_family");
    families.iter().for_each(|f| conf += &format!(",{f}"));
    conf += ",n\n";
    let mut off: Vec<(usize, String, String)> = vec![];
    for f in &families {
        conf += f;
        let nf = rows.iter().filter(|r| r.family == *f).count();
        for g in &families {
            let k = rows.iter().filter(|r| r.family == *f && fam(&r.top[0]) == *g).count();
            conf += &format!(",{k}");
            if f != g && k > 0 {
                off.push((k, f.clone(), g.clone()));
            }
        }
        conf += &format!(",{nf}\n");
    }
    conf += "\ntrue_group,wood,not_wood,n\n";
    for (label, w) in [("wood", true), ("not_wood", false)] {
        let sel: Vec<&Row> = rows.iter().filter(|r| is_wood(&r.material) == w).collect();
        let k = sel.iter().filter(|r| is_wood(&r.top[0])).count();
        conf += &format!("{label},{k},{},{}\n", sel.len() - k, sel.len());
    }
    off.sort_by_key(|o| std::cmp::Reverse(o.0));
    println!("\nfamily confusions (true -> top-1 family, count):");
    for (k, f, g) in &off {
        println!("  {f} -> {g}: {k}");
    }
    let mut pairs: BTreeMap<(String, String), usize> = BTreeMap::new();
    for r in rows.iter().filter(|r| !top1(r)) {
        *pairs.entry((r.material.clone(), r.top[0].clone())).or_default() += 1;
    }
    let mut pairs: Vec<_> = pairs.into_iter().collect();
    pairs.sort_by_key(|p| std::cmp::Reverse(p.1));
    println!("\nmost frequent material confusions (true -> top-1, count):");
    for ((a, b), k) in pairs.iter().take(15) {
        println!("  {a} -> {b}: {k}");
    }

    let out = &args.out;
    if let Some(dir) = out.parent() {
        std::fs::create_dir_all(dir)?;
    }
    std::fs::write(out, csv)?;
    let conf_path = out.with_file_name(format!(
        "{}_confusion.csv",
        out.file_stem().and_then(|s| s.to_str()).unwrap_or("texture_search")
    ));
    std::fs::write(&conf_path, conf)?;
    let mut bars = vec![(format!("all ({n_all})"), vec![pct(a1, n_all), pct(a3, n_all), pct(f1, n_all)])];
    bars.extend(fam_bars);
    bars.extend(var_bars);
    let svg = psdr::report::chart::BarChart {
        title: format!(
            "Material search, {n_all} crops of {n} library materials: top-1 {:.0} %, top-3 {:.0} %",
            pct(a1, n_all),
            pct(a3, n_all)
        ),
        unit: "%".into(),
        series: vec!["top-1 material".into(), "top-3 material".into(), "top-1 in the true family".into()],
        rows: bars,
        stacked: false,
    }
    .svg();
    let svg_path = out.with_extension("svg");
    std::fs::write(&svg_path, format!("{svg}\n"))?;
    println!("wrote {}, {} and {}", out.display(), conf_path.display(), svg_path.display());
    Ok(())
}
