//! The colourised depth picture: matplotlib's published viridis anchors at the right depths,
//! invalid pixels black, through a real PNG file.

use kestrel_vision::image::load_unchanged;
use kestrel_vision::{DepthMap, DepthRange, VisionError, write_depth_png};
use opencv::core::{MatTraitConst, Vec3b};

/// matplotlib's viridis at 0, ¼, ½, ¾ and 1 (RGB), from its published colour table.
const VIRIDIS_RGB: [(f32, [u8; 3]); 5] = [
    (0.0, [0x44, 0x01, 0x54]),
    (0.25, [0x3b, 0x52, 0x8b]),
    (0.5, [0x21, 0x91, 0x8c]),
    (0.75, [0x5e, 0xc9, 0x62]),
    (1.0, [0xfd, 0xe7, 0x25]),
];

#[test]
fn depths_take_viridis_colours_on_inverse_depth_and_invalid_is_black() {
    let range = DepthRange { near_m: 0.5, far_m: 20.0 };
    // The depth at each anchor: 1/z linear from 1/20 (t = 0) to 1/0.5 (t = 1).
    let depth_at = |t: f32| 1.0 / (1.0 / 20.0 + t * (2.0 - 1.0 / 20.0));
    let mut values: Vec<f32> = VIRIDIS_RGB.iter().map(|&(t, _)| depth_at(t)).collect();
    values.extend([f32::NAN, 0.1, 500.0]);
    let depth = DepthMap { width: values.len(), height: 1, values };
    let path = std::env::temp_dir().join(format!("kestrel-depth-{}.png", std::process::id()));
    write_depth_png(&depth, range, &path).unwrap();
    let image = load_unchanged(&path).unwrap();
    let _ = std::fs::remove_file(&path);
    assert_eq!((image.cols(), image.rows(), image.channels()), (8, 1, 3));
    let rgb = |x: i32| {
        let [b, g, r] = image.at_2d::<Vec3b>(0, x).unwrap().0;
        [r, g, b]
    };
    for (x, (t, want)) in VIRIDIS_RGB.iter().enumerate() {
        let got = rgb(x as i32);
        let close = got.iter().zip(want).all(|(a, b)| a.abs_diff(*b) <= 3);
        assert!(close, "t = {t}: got {got:?}, viridis {want:?}");
    }
    assert_eq!(rgb(5), [0, 0, 0], "no depth is black");
    assert_eq!(rgb(6), rgb(4), "nearer than the range clamps to its near colour");
    assert_eq!(rgb(7), rgb(0), "farther than the range clamps to its far colour");
}

#[test]
fn bad_ranges_and_names_are_refused() {
    let depth = DepthMap { width: 1, height: 1, values: vec![1.0] };
    let png = std::env::temp_dir().join("kestrel-depth-bad.png");
    for (near_m, far_m) in [(0.0, 10.0), (5.0, 5.0), (10.0, 1.0), (f32::NAN, 1.0)] {
        let err = write_depth_png(&depth, DepthRange { near_m, far_m }, &png).unwrap_err();
        assert!(matches!(err, VisionError::Params(_)), "{err}");
    }
    let err = write_depth_png(&depth, DepthRange::default(), &png.with_extension("jpg")).unwrap_err();
    assert!(err.to_string().contains(".png"), "{err}");
    let short = DepthMap { width: 2, height: 2, values: vec![1.0] };
    assert!(matches!(write_depth_png(&short, DepthRange::default(), &png), Err(VisionError::Input(_))));
}
