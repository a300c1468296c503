//! What the benchmarks share: the seed rig's frame.

use synth::Image16;

/// Sides of the seed rig's frames (px).
pub const W: u32 = 4096;
pub const H: u32 = 3072;

/// The seed rig's frame: camera 2 of the renderer's default campaign at its
/// first instant (spheres A, B, C of 20, 15, 10 mm at ≈ 460 mm, full noise).
pub fn seed_image() -> Image16 {
    let config = synth::Config::default();
    let rig = synth::SynthRig::from_config(&config).unwrap();
    let plan = synth::Plan::new(&config).unwrap();
    let spheres = plan.spheres_at(&plan.instants[0]);
    let key = synth::NoiseKey {
        seed: 1,
        frame: 0,
        camera: 2,
    };
    let img = rig
        .camera(2)
        .unwrap()
        .render(&spheres, key, config.render.max_depth)
        .unwrap();
    assert_eq!((img.width(), img.height()), (W, H));
    img
}
