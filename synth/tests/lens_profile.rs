//! Lenses as measured (docs/renderer.md): a profile-rendered flat field
//! follows the lensfun "pa" profile about its decentred centre, the cameras
//! take the profile's distortion, and bad profile settings are refused with
//! the key named. The expected RI is computed here from lensfun's published
//! numbers and normalisation, independently of the renderer's code.

#![allow(clippy::unwrap_used)]

use formats::{OutputPlan, Truth, read_json};
use synth::{Config, IlluminationModel, NoProgress, SynthRig, lens_profile, write_target_scene};

mod common;

/// lensfun's "Nikon AF Nikkor 35-70mm f/2.8", pa at 40 mm, f/8 (data/db/slr-nikon.xml).
const PA_35_70_AT_40_F8: [f64; 3] = [-0.3735, 0.1832, -0.0571];
/// lensfun's r = 1 of vignetting: half the diagonal of the 36 × 24 mm frame (mm).
const HALF_DIAGONAL_MM: f64 = 21.633_307_652_783_937;

/// The seed's rig at 512 × 384 through the 35–70 profile, decentred by `offset_um`.
fn config(offset_um: [f64; 2]) -> Config {
    let mut c = common::small_config();
    c.optics.illumination = IlluminationModel::Profile;
    c.optics.lens = Some("nikon-af-35-70-f2.8-at-40-f8".into());
    c.optics.profile_centre_offset_um = offset_um;
    c.validate().unwrap();
    c
}

/// The pa model at pixel (u, v) about centre `c` (px), pixel pitch `pixel_mm`.
fn pa(u: f64, v: f64, c: [f64; 2], pixel_mm: f64) -> f64 {
    let r2 = ((u - c[0]).powi(2) + (v - c[1]).powi(2)) * (pixel_mm / HALF_DIAGONAL_MM).powi(2);
    let [k1, k2, k3] = PA_35_70_AT_40_F8;
    1.0 + k1 * r2 + k2 * r2 * r2 + k3 * r2 * r2 * r2
}

/// Flat field through a measured, decentred profile: the mean of each 64 ×
/// 64 block, offset removed, over gain × radiance, equals the block's mean
/// profile within 1e-3 relative (the shot and read noise of a block mean is
/// ≈ 0.9 %/64 = 1.4e-4, so the limit is 7 of them); the
/// same profile about the principal point misses by more than 3e-3 somewhere
/// (the decentring shows). The profile's RI is no cos⁴θ·J on top: it falls
/// to the pa value at the corners (≈ 0.86), not below it.
#[test]
fn flat_field_follows_the_decentred_profile() {
    let offset_um = [400.0, -300.0];
    let c = config(offset_um);
    let rig = SynthRig::from_config(&c).unwrap();
    let cam = rig.camera(2).unwrap();
    let flat = cam.flat_field(c.seed);
    let (s, l) = (&cam.sensor, cam.flat_field_radiance_e());
    let pixel_mm = c.sensor.pixel_mm;
    let k = &cam.camera.intrinsics;
    let centre = [
        k.cx + offset_um[0] / 1000.0 / pixel_mm,
        k.cy + offset_um[1] / 1000.0 / pixel_mm,
    ];
    let block = 64;
    let (mut worst, mut worst_centred) = (0.0_f64, 0.0_f64);
    for bv in 0..384 / block {
        for bu in 0..512 / block {
            let (mut got, mut want, mut centred) = (0.0, 0.0, 0.0);
            for v in bv * block..(bv + 1) * block {
                for u in bu * block..(bu + 1) * block {
                    let dn = f64::from(flat.get_pixel(u, v).0[0]);
                    got += (dn - s.offset_dn) / (s.gain_dn_per_e * l);
                    want += pa(f64::from(u), f64::from(v), centre, pixel_mm);
                    centred += pa(f64::from(u), f64::from(v), [k.cx, k.cy], pixel_mm);
                }
            }
            worst = worst.max((got / want - 1.0).abs());
            worst_centred = worst_centred.max((got / centred - 1.0).abs());
        }
    }
    eprintln!("block means vs the decentred profile: {worst:.2e}; vs centred: {worst_centred:.2e}");
    assert!(worst < 1e-3, "{worst}");
    assert!(
        worst_centred > 3e-3,
        "the decentring does not show ({worst_centred})"
    );
    let corner = pa(0.0, 0.0, centre, pixel_mm);
    assert!((0.8..0.9).contains(&corner), "{corner}");

    // truth.json describes the profile's RI and the profile itself.
    let dir = tempfile::tempdir().unwrap();
    write_target_scene(&c, dir.path(), &mut OutputPlan::new(false), &NoProgress).unwrap();
    let truth: Truth = read_json(&dir.path().join("truth.json")).unwrap();
    let t = truth.cameras.iter().find(|t| t.model.id == 2).unwrap();
    assert_eq!(t.extra["illumination"]["model"], "profile");
    let centre_json = t.extra["illumination"]["centre_px"].as_array().unwrap();
    assert!((centre_json[0].as_f64().unwrap() - centre[0]).abs() < 1e-9);
    assert_eq!(
        t.extra["lens_profile"]["profile"]["vignetting_pa"][0],
        -0.3735
    );
}

/// The profile's distortion replaces each camera's radial terms (a focal
/// length scale and k1, k2, k3 fitted to ptlens; p1, p2 stay the camera's),
/// and the camera's radial image height follows ptlens computed here (image
/// height in lensfun's units: 12 mm for a 3:2 full-frame calibration, the
/// paraxial scale d = 1 − a − b − c) within the fit's stated residual.
#[test]
fn cameras_take_the_profiles_distortion() {
    let mut c = config([0.0, 0.0]);
    c.optics.illumination = IlluminationModel::Lens;
    c.optics.lens = Some("nikon-af-s-24-70-f2.8g-at-40".into());
    c.validate().unwrap();
    let rig = SynthRig::from_config(&c).unwrap();
    let profile = lens_profile::built_in("nikon-af-s-24-70-f2.8g-at-40").unwrap();
    let [a, b, cc] = profile.distortion_ptlens.unwrap();
    assert!(
        profile.vignetting_pa.is_none(),
        "lensfun has no vignetting for this lens"
    );
    let d = 1.0 - a - b - cc;
    let (pixel_mm, o) = (c.sensor.pixel_mm, &c.optics);
    let pd_mm = o.focal_mm * o.focus_distance_mm / (o.focus_distance_mm - o.focal_mm);
    for (cam, cfg) in rig.cameras.iter().zip(&c.rig.cameras) {
        let dist = cam.camera.distortion;
        assert_eq!((dist.p1, dist.p2), (cfg.distortion.p1, cfg.distortion.p2));
        // The paraxial camera of the configuration, before the fit.
        let mut k0 = cam.camera.intrinsics;
        k0.fx = pd_mm * (1.0 + cfg.focal_error_percent / 100.0) / pixel_mm;
        k0.fy = k0.fx;
        let fit = profile
            .brown_in_pixels(&k0, 512, 384, pixel_mm)
            .unwrap()
            .unwrap();
        assert_eq!([dist.k1, dist.k2, dist.k3], fit.k);
        let fx = cam.camera.intrinsics.fx;
        assert!((fx / (fit.scale * k0.fx) - 1.0).abs() < 1e-15);
        // Radial image height along the diagonal, out to the corner.
        for frac in [0.05, 0.2, 0.5, 0.8, 1.0] {
            let ideal_px = frac * (255.5_f64).hypot(191.5);
            let ru = ideal_px * pixel_mm / (d * 12.0);
            let want = ru * (a * ru.powi(3) + b * ru * ru + cc * ru + d) * 12.0 / pixel_mm;
            let r = ideal_px / k0.fx;
            let got = fx * r * (1.0 + dist.k1 * r * r + dist.k2 * r.powi(4) + dist.k3 * r.powi(6));
            assert!(
                (got - want).abs() <= fit.max_residual_px + 1e-9,
                "camera {} at {ideal_px:.1} px: {got} vs {want}",
                cam.id
            );
        }
        eprintln!(
            "camera {}: scale {:.6}, k {:?}, residual {:.4} px",
            cam.id, fit.scale, fit.k, fit.max_residual_px
        );
        assert!(fit.max_residual_px < 0.35, "{}", fit.max_residual_px);
    }
}

/// Settings a profile cannot serve are refused, naming the key.
#[test]
fn bad_profile_settings_are_named() {
    let refuse = |edit: &dyn Fn(&mut Config), needle: &str| {
        let mut c = config([0.0, 0.0]);
        edit(&mut c);
        let e = c.validate().unwrap_err().to_string();
        assert!(e.contains(needle), "{e}");
    };
    // The seed's lens has no measured vignetting in lensfun.
    refuse(
        &|c| c.optics.lens = Some("nikon-af-s-24-70-f2.8g-at-40".into()),
        "has no measured vignetting",
    );
    refuse(
        &|c| c.optics.lens = Some("no-such-lens".into()),
        "nikon-af-35-70-f2.8-at-40-f8",
    );
    refuse(
        &|c| {
            c.optics.profile = Some(lens_profile::built_in("nikon-af-35-70-f2.8-at-40-f8").unwrap())
        },
        "not both",
    );
    refuse(&|c| c.optics.lens = None, "needs a lens profile");
    refuse(
        &|c| {
            c.optics.illumination = IlluminationModel::Lens;
            c.optics.profile_centre_offset_um = [10.0, 0.0];
        },
        "optics.profile_centre_offset_um",
    );
    refuse(
        &|c| {
            c.optics.lens = None;
            c.optics.profile = Some(synth::config::LensProfile {
                vignetting_pa: Some([-3.0, 0.0, 0.0]),
                ..synth::config::LensProfile::default()
            });
        },
        "must stay positive",
    );
    // An inline profile reads from TOML like the built-in one.
    let text = "[optics]\nillumination = \"profile\"\n[optics.profile]\nname = \"x\"\n\
                vignetting_pa = [-0.3735, 0.1832, -0.0571]\n";
    let c = Config::from_toml_str(text, None).unwrap();
    assert_eq!(
        c.optics.lens_profile().unwrap().unwrap().vignetting_pa,
        Some(PA_35_70_AT_40_F8)
    );
    // And the effective configuration writes it back.
    let again = Config::from_toml_str(&c.to_toml().unwrap(), None).unwrap();
    assert_eq!(again, c);
}
