//! PSNR, SSIM and the SSIM gradient against torch (3DGS's SSIM formula, float64, autograd) and
//! scikit-image, computed by `tools/fixtures/make_photometric_fixtures.py`.

use serde::Deserialize;
use splatseg_eval::{psnr, ssim, ssim_map, ssim_with_grad};

#[derive(Deserialize)]
struct Fixture {
    cases: Vec<Case>,
}

/// One image pair; `a`, `b`, `grad`: `[H, W, C]`.
#[derive(Deserialize)]
struct Case {
    name: String,
    width: usize,
    height: usize,
    channels: usize,
    a: Vec<f32>,
    b: Vec<f32>,
    ssim: f64,
    grad: Vec<f64>,
    psnr: f64,
    /// scikit-image's `structural_similarity` (reflect padding, 5-px border cropped).
    skimage_ssim: f64,
    /// The torch (3DGS) SSIM map averaged over pixels at least 5 px from every border.
    interior_ssim: f64,
}

fn cases() -> Vec<Case> {
    let text = include_str!("fixtures/photometric/reference.json");
    let fixture: Fixture = serde_json::from_str(text).expect("fixture parses");
    assert_eq!(fixture.cases.len(), 2);
    fixture.cases
}

#[test]
fn psnr_matches_numpy() {
    for c in cases() {
        let ours = psnr(&c.a, &c.b, c.width, c.height, c.channels).unwrap();
        assert!((ours - c.psnr).abs() < 1e-9, "{}: psnr {ours} vs {}", c.name, c.psnr);
    }
}

#[test]
fn ssim_matches_torch_3dgs_formula() {
    for c in cases() {
        let ours = ssim(&c.a, &c.b, c.width, c.height, c.channels).unwrap();
        println!(
            "{}: ssim ours {ours:.15} torch {:.15} |diff| {:.2e}",
            c.name,
            c.ssim,
            (ours - c.ssim).abs()
        );
        assert!((ours - c.ssim).abs() < 1e-9, "{}: ssim {ours} vs torch {}", c.name, c.ssim);
    }
}

#[test]
fn ssim_gradient_matches_torch_autograd() {
    for c in cases() {
        let (value, grad) = ssim_with_grad(&c.a, &c.b, c.width, c.height, c.channels).unwrap();
        assert!((value - c.ssim).abs() < 1e-9, "{}: ssim {value} vs torch {}", c.name, c.ssim);
        assert_eq!(grad.len(), c.grad.len());
        let max_ref = c.grad.iter().fold(0.0f64, |m, g| m.max(g.abs()));
        assert!(max_ref > 0.0);
        let (worst_i, worst) = grad
            .iter()
            .zip(&c.grad)
            .map(|(&g, &r)| (f64::from(g) - r).abs() / max_ref)
            .enumerate()
            .fold((0, 0.0f64), |best, (i, e)| if e > best.1 { (i, e) } else { best });
        println!("{}: max |grad − torch| / max |torch| = {worst:.2e} at {worst_i}", c.name);
        assert!(
            worst < 1e-6,
            "{}: gradient at index {worst_i}: ours {} vs torch {} (relative to max {max_ref})",
            c.name,
            grad[worst_i],
            c.grad[worst_i]
        );
    }
}

/// scikit-image pads by reflection and drops a 5-px border before averaging, so its value is not
/// 3DGS's; inside that border the two maps are the same function of the images, so the interior
/// mean of our map must equal it. The whole-image values really differ (recorded, not hidden).
#[test]
fn ssim_interior_matches_scikit_image() {
    for c in cases() {
        let map = ssim_map(&c.a, &c.b, c.width, c.height, c.channels).unwrap();
        let (w, h, ch) = (c.width, c.height, c.channels);
        let mut sum = 0.0;
        let mut n = 0usize;
        for y in 5..h - 5 {
            for x in 5..w - 5 {
                for k in 0..ch {
                    sum += map[(y * w + x) * ch + k];
                    n += 1;
                }
            }
        }
        let interior = sum / n as f64;
        assert!((interior - c.interior_ssim).abs() < 1e-9, "{}: interior {interior} vs torch", c.name);
        assert!(
            (interior - c.skimage_ssim).abs() < 1e-9,
            "{}: interior mean {interior} vs skimage {}",
            c.name,
            c.skimage_ssim
        );
        let whole = ssim(&c.a, &c.b, w, h, ch).unwrap();
        println!(
            "{}: 3DGS ssim {whole:.6} vs skimage {:.6} (border handling: zero padding + whole map vs reflect + cropped)",
            c.name, c.skimage_ssim
        );
        assert!((whole - c.skimage_ssim).abs() > 1e-3, "{}: the border handling should matter here", c.name);
    }
}
