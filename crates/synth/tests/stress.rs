//! The stress families produce what they promise: thin posts 2–4 px wide at any resolution,
//! multi-tone surfaces cut into parts whose features agree, border-cut foreground objects, the
//! extra SAM noise, and failure classes in `gt/objects.json`.

use splatseg_synth::features::{cosine, Embeddings};
use splatseg_synth::{generate, write, FailureClass, Family, SynthConfig, SynthScene};

fn small(family: Family, seed: u64, views: usize) -> SynthConfig {
    SynthConfig { views, ..family.config(seed) }
}

/// Median over views and rows of the number of pixels of `id` per image row.
fn median_row_width(s: &SynthScene, id: u32) -> Option<usize> {
    let mut widths = Vec::new();
    for v in &s.views {
        let (w, h) = v.gt_instance.size();
        for y in 0..h {
            let n = (0..w).filter(|&x| *v.gt_instance.get(x, y) == id).count();
            if n > 0 {
                widths.push(n);
            }
        }
    }
    widths.sort_unstable();
    widths.get(widths.len() / 2).copied()
}

#[test]
fn thin_posts_are_two_to_four_pixels_wide_at_320_and_at_1280() {
    for (seed, (w, h), views) in [(0, (320, 240), 3), (1, (320, 240), 3), (0, (1280, 960), 2)] {
        {
            let mut config = small(Family::Thin, seed, views);
            config.width = w;
            config.height = h;
            let s = generate(&config).expect("generate");
            let classes = s.failure_classes();
            let posts: Vec<u32> = s
                .objects
                .iter()
                .zip(&classes)
                .filter(|(_, c)| c.contains(&FailureClass::Thin))
                .map(|(o, _)| o.id)
                .collect();
            assert!(posts.len() >= 2, "seed {seed}: {} posts", posts.len());
            for id in posts {
                let width = median_row_width(&s, id).expect("the post is visible");
                println!("seed {seed} {w}x{h}: post {id} median width {width} px");
                assert!((2..=4).contains(&width), "seed {seed} {w}x{h}: post {id} is {width} px wide");
            }
        }
    }
}

#[test]
fn multi_tone_walls_are_one_instance_in_several_parts_with_agreeing_features() {
    let mut found = 0;
    for seed in 0..6 {
        let s = generate(&small(Family::MultiTone, seed, 2)).expect("generate");
        let classes = s.failure_classes();
        for wall in [2u32, 3] {
            assert!(classes[wall as usize - 1].contains(&FailureClass::MultiTone), "seed {seed}");
            let parts: std::collections::BTreeSet<u8> = s
                .views
                .iter()
                .flat_map(|v| v.gt_instance.data.iter().zip(&v.gt_part.data).filter(|(&i, _)| i == wall))
                .map(|(_, &p)| p)
                .collect();
            if parts.len() >= 2 {
                found += 1;
            }
        }
    }
    assert!(found >= 8, "two-tone walls show both tones in only {found} of 12 walls");
    // The parts' embeddings agree as DINOv2's parts of one object do.
    let e = Embeddings::new(3, 384, 12, &[], &splatseg_synth::CueConfig::default());
    let c = cosine(&e.part(2, 0), &e.part(2, 1));
    assert!((0.85..0.97).contains(&c), "parts of one wall: cos {c:.3}");
    let other = cosine(&e.part(2, 0), &e.part(5, 0));
    assert!(other < 0.7, "different objects: cos {other:.3}");
}

#[test]
fn border_family_has_foreground_objects_cut_in_most_views() {
    let mut cut = 0;
    let mut total = 0;
    for seed in 0..4 {
        let s = generate(&small(Family::Border, seed, 8)).expect("generate");
        let classes = s.failure_classes();
        for (o, c) in s.objects.iter().zip(&classes) {
            if o.name.starts_with("foreground_") {
                total += 1;
                cut += usize::from(c.contains(&FailureClass::BorderCut));
            }
        }
    }
    assert!(total >= 4, "{total} foreground objects");
    assert!(cut * 4 >= total * 3, "only {cut} of {total} foreground objects are cut by the border");
}

#[test]
fn sam_noise_knobs_merge_adjacent_objects_and_dilate_masks() {
    let mut base = small(Family::Clutter, 2, 4);
    base.sam.whole_object_probability = 0.0;
    base.sam.wrong_merge_probability = 0.0;
    let plain = generate(&base).expect("generate");
    let mut noisy_config = base.clone();
    noisy_config.sam.adjacent_merge_probability = 1.0;
    noisy_config.sam.wrong_merge_replaces_probability = 0.0;
    noisy_config.sam.dilate_probability = 1.0;
    let noisy = generate(&noisy_config).expect("generate");
    let mut merged = 0;
    for (p, n) in plain.views.iter().zip(&noisy.views) {
        // A mask covering pixels of two different objects (ids ≥ 4) is a wrong merge.
        let spans_two = |m: &splatseg_scene::sam::SamMask| {
            let mask = m.segmentation.decode().expect("mask");
            let mut ids: Vec<u32> = mask
                .data
                .iter()
                .zip(&n.gt_instance.data)
                .filter(|(&on, &id)| on && id >= 4)
                .map(|(_, &id)| id)
                .collect();
            ids.sort_unstable();
            ids.dedup();
            // Dilation adds a one-pixel rim of neighbours: count objects with many pixels.
            ids.iter()
                .filter(|&&id| {
                    mask.data.iter().zip(&n.gt_instance.data).filter(|(&on, &g)| on && g == id).count() > 50
                })
                .count()
                >= 2
        };
        merged += n.sam_masks.iter().filter(|m| spans_two(m)).count();
        let area = |masks: &[splatseg_scene::sam::SamMask]| masks.iter().map(|m| m.area).sum::<u64>();
        assert!(area(&n.sam_masks) > area(&p.sam_masks), "{}: dilation grows the masks", n.stem);
    }
    assert!(merged >= 4, "only {merged} wrong merges of adjacent objects");
}

#[test]
fn random_families_write_failure_classes_and_the_default_does_not() {
    let dir = tempfile::tempdir().expect("tmp");
    let s = generate(&small(Family::Clutter, 5, 2)).expect("generate");
    write(dir.path(), &s).expect("write");
    let doc: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("gt/objects.json")).expect("read"))
            .expect("json");
    assert_eq!(doc["config"]["family"], "clutter");
    let objects = doc["objects"].as_array().expect("objects");
    assert!(objects.iter().all(|o| !o["classes"].as_array().expect("classes").is_empty()));
    let named = |class: &str| {
        objects.iter().filter(|o| o["classes"].as_array().unwrap().contains(&class.into())).count()
    };
    assert_eq!(named("white_pair"), 2);
    assert!(named("stacked") >= 2 && named("touching") >= 2 && named("room") == 3);
    let d = generate(&SynthConfig { views: 2, width: 96, height: 72, ..SynthConfig::default() })
        .expect("generate");
    assert!(d.object_infos().iter().all(|o| o.classes.is_empty()));
    assert!(d.failure_classes().iter().all(|c| !c.is_empty()));
}

#[test]
fn stress_knobs_are_validated() {
    let mut c = Family::Rooms.config(0);
    c.room.objects = [9, 3];
    assert!(generate(&c).is_err());
    let mut c = SynthConfig::default();
    c.room.thin_posts = 2;
    assert!(generate(&c).is_err(), "plan layouts take no thin posts");
    let mut c = Family::Rooms.config(0);
    c.sam.hole_radius_px = [0, 2];
    assert!(generate(&c).is_err());
    for bad in [
        |c: &mut SynthConfig| c.cues.gaussian_thickness = 0.0,
        |c: &mut SynthConfig| c.cues.gaussian_tilt_deg = f64::NAN,
        |c: &mut SynthConfig| c.cues.gaussian_floaters = 1.5,
        |c: &mut SynthConfig| c.cues.gaussian_scale_spread = -0.1,
    ] {
        let mut c = Family::Rooms.config(0);
        bad(&mut c);
        let err = generate(&c).expect_err("a bad Gaussian knob");
        assert!(err.to_string().contains("cues.gaussian_"), "{err}");
    }
}

/// `blind_rough`'s Gaussians are what its knobs say: the same samples as exact discs, each
/// shortest axis tilted off the surface normal by the drawn spread, thicker, and the centres
/// moved along the normal; with the knobs at their defaults the discs are exact.
#[test]
fn rough_gaussians_are_tilted_thicker_and_off_the_surface_by_the_drawn_amounts() {
    let rough = SynthConfig { views: 3, width: 160, height: 120, ..Family::BlindRough.config(3) };
    let exact = SynthConfig {
        cues: splatseg_synth::CueConfig {
            gaussian_tilt_deg: 0.0,
            gaussian_thickness: 0.02,
            gaussian_offset: 0.0,
            ..rough.cues.clone()
        },
        ..rough.clone()
    };
    let (a, b) = (generate(&exact).expect("exact"), generate(&rough).expect("rough"));
    assert_eq!(a.gaussian_ids, b.gaussian_ids, "the same samples");
    let (na, nb) =
        (a.gaussians.normals.as_ref().expect("normals"), b.gaussians.normals.as_ref().expect("normals"));
    let angles: Vec<f64> = na
        .iter()
        .zip(nb)
        .map(|(p, q)| {
            let dot: f32 = (0..3).map(|c| p[c] * q[c]).sum();
            (dot.clamp(-1.0, 1.0) as f64).acos().to_degrees()
        })
        .collect();
    let mean = angles.iter().sum::<f64>() / angles.len() as f64;
    // Two tangent axes of standard deviation σ: the tilt is Rayleigh, mean σ·√(π/2).
    let expected = rough.cues.gaussian_tilt_deg * (std::f64::consts::PI / 2.0).sqrt();
    assert!((mean - expected).abs() < 0.05 * expected, "mean tilt {mean:.2}° vs {expected:.2}°");
    let thickness =
        |s: &splatseg_synth::SynthScene| s.gaussians.log_scales[0][2] - s.gaussians.log_scales[0][0];
    let ratio = (thickness(&b) - thickness(&a)).exp() as f64;
    assert!((ratio - rough.cues.gaussian_thickness / 0.02).abs() < 1e-3, "thickness × {ratio}");
    // Each centre moved along its surface normal only, by the drawn spread.
    let spacing = (a.gaussians.log_scales[0][0].exp() / 0.6) as f64;
    let offsets: Vec<f64> = (0..na.len())
        .map(|i| {
            (0..3).map(|c| ((b.gaussians.means[i][c] - a.gaussians.means[i][c]) * na[i][c]) as f64).sum()
        })
        .collect();
    let rms = (offsets.iter().map(|o| o * o).sum::<f64>() / offsets.len() as f64).sqrt() / spacing;
    assert!((rms - rough.cues.gaussian_offset).abs() < 0.05 * rough.cues.gaussian_offset, "offset rms {rms}");
    assert!(rough.cues.gaussian_tilt_deg >= 15.0 && mean > 15.0, "{mean}");
}

/// `blind_trained`'s Gaussians are what its knobs say beyond `blind_rough`'s: the same samples,
/// in-plane log scales spread by the drawn amount per axis, and the drawn share of floaters, each
/// moved 2–8 spacings off its surface towards a camera and faint.
#[test]
fn trained_gaussians_have_spread_sizes_and_the_drawn_share_of_floaters() {
    let trained = SynthConfig { views: 3, width: 160, height: 120, ..Family::BlindTrained.config(2) };
    let fit = trained.cues.clone();
    let plain = SynthConfig {
        cues: splatseg_synth::CueConfig { gaussian_scale_spread: 0.0, gaussian_floaters: 0.0, ..fit.clone() },
        ..trained.clone()
    };
    let (a, b) = (generate(&plain).expect("plain"), generate(&trained).expect("trained"));
    assert_eq!(a.gaussian_ids, b.gaussian_ids, "the same samples");
    let n = a.gaussians.means.len();
    assert!(n > 1000, "{n} Gaussians");
    let (la, lb) = (&a.gaussians.log_scales, &b.gaussians.log_scales);
    let spread: Vec<f64> = (0..n).flat_map(|i| (0..2).map(move |k| (lb[i][k] - la[i][k]) as f64)).collect();
    let rms = (spread.iter().map(|d| d * d).sum::<f64>() / spread.len() as f64).sqrt();
    assert!(
        (rms - fit.gaussian_scale_spread).abs() < 0.05 * fit.gaussian_scale_spread,
        "log-scale rms {rms}"
    );
    let spacing = (a.gaussians.log_scales[0][0].exp() / 0.6) as f64;
    let moved: Vec<usize> = (0..n)
        .filter(|&i| {
            let d: f32 = (0..3).map(|c| (b.gaussians.means[i][c] - a.gaussians.means[i][c]).powi(2)).sum();
            d > 0.0
        })
        .collect();
    let share = moved.len() as f64 / n as f64;
    assert!((share - fit.gaussian_floaters).abs() < 0.25 * fit.gaussian_floaters, "floaters {share}");
    for &i in &moved {
        let d: f32 = (0..3).map(|c| (b.gaussians.means[i][c] - a.gaussians.means[i][c]).powi(2)).sum();
        let d = d.sqrt() as f64 / spacing;
        assert!((1.99..8.01).contains(&d), "floater {i} moved {d} spacings");
        let opacity = 1.0 / (1.0 + (-b.gaussians.raw_opacities[i] as f64).exp());
        assert!((0.1..0.4).contains(&opacity), "floater {i} opacity {opacity}");
    }
}
