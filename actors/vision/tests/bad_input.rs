//! Bad input files of every format `kestrel calibrate`, `disparity` and `stereo` read — the
//! calibration YAML, PNG/PGM/JPEG images, PFM disparities — give an error or a result, never a
//! panic or an abort (OpenCV's exceptions come back as `Err`); and a calibration a matcher could
//! not use is refused naming the file and the key.

use std::path::{Path, PathBuf};

use kestrel_proto::bad_input::mutate;
use kestrel_vision::disparity_file::{read_pfm, write_disparity};
use kestrel_vision::image::{load_gray, load_unchanged};
use kestrel_vision::score::GroundTruth;
use kestrel_vision::{DisparityMap, StereoCalibration};
use proptest::prelude::*;

fn scratch(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("vision-bad-input");
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(format!("{}-{name}", std::process::id()))
}

fn data(name: &str) -> Vec<u8> {
    std::fs::read(Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data").join(name)).unwrap()
}

/// A rectified 640×480 pair, f = 500 px, 0.1 m baseline: what `kestrel calibrate` writes.
fn nominal() -> StereoCalibration {
    let k = [[500.0, 0.0, 320.0], [0.0, 500.0, 240.0], [0.0, 0.0, 1.0]];
    let identity = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    StereoCalibration {
        image_width: 640,
        image_height: 480,
        k1: k,
        d1: vec![0.0; 5],
        k2: k,
        d2: vec![0.0; 5],
        r: identity,
        t: [-0.1, 0.0, 0.0],
        r1: identity,
        r2: identity,
        p1: [[500.0, 0.0, 320.0, 0.0], [0.0, 500.0, 240.0, 0.0], [0.0, 0.0, 1.0, 0.0]],
        p2: [[500.0, 0.0, 320.0, -50.0], [0.0, 500.0, 240.0, 0.0], [0.0, 0.0, 1.0, 0.0]],
        q: [[1.0, 0.0, 0.0, -320.0], [0.0, 1.0, 0.0, -240.0], [0.0, 0.0, 0.0, 500.0], [0.0, 0.0, 10.0, 0.0]],
        rms_px: 0.3,
        depth_scale: 1.0,
    }
}

fn nominal_yaml() -> Vec<u8> {
    let path = scratch("nominal.yaml");
    nominal().save(&path).unwrap();
    std::fs::read(&path).unwrap()
}

#[test]
fn a_calibration_without_focal_lengths_or_with_a_singular_rotation_is_refused_by_key() {
    let path = scratch("round-trip.yaml");
    nominal().save(&path).unwrap();
    assert_eq!(StereoCalibration::load(&path).unwrap(), nominal());

    let mut no_focal = nominal();
    no_focal.k1[0][0] = 0.0;
    no_focal.k1[1][1] = 0.0;
    let mut negative = nominal();
    negative.k2[1][1] = -500.0;
    let mut singular = nominal();
    singular.r = [[0.0; 3]; 3];
    let mut scaled = nominal();
    scaled.r1 = [[2.0, 0.0, 0.0], [0.0, 2.0, 0.0], [0.0, 0.0, 2.0]];
    for (calibration, key) in [(no_focal, "K1"), (negative, "K2"), (singular, "R "), (scaled, "R1")] {
        let path = scratch("bad.yaml");
        calibration.save(&path).unwrap();
        let err = StereoCalibration::load(&path).expect_err(key).to_string();
        assert!(err.contains("bad.yaml") && err.contains(key), "{key}: {err}");
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn mutated_calibration_files_load_or_are_refused(
        edits in prop::collection::vec((any::<u8>(), any::<usize>(), any::<u8>()), 1..6),
    ) {
        let path = scratch("mutated.yaml");
        std::fs::write(&path, mutate(&nominal_yaml(), &edits)).unwrap();
        if let Ok(calibration) = StereoCalibration::load(&path) {
            prop_assert!(calibration.check().is_ok());
        }
    }

    #[test]
    fn arbitrary_bytes_are_no_calibration_file(bytes in prop::collection::vec(any::<u8>(), 0..512)) {
        let path = scratch("arbitrary.yaml");
        std::fs::write(&path, &bytes).unwrap();
        let _ = StereoCalibration::load(&path);
    }

    #[test]
    fn mutated_images_load_or_are_refused(
        which in 0..4usize,
        edits in prop::collection::vec((any::<u8>(), any::<usize>(), any::<u8>()), 1..6),
    ) {
        let (name, valid) = match which {
            0 => ("image.png", data("middlebury2003_teddy/im2.png")),
            1 => ("image.pgm", data("middlebury2003_teddy/disp2.pgm")),
            2 => ("image.jpg", data("opencv_stereo_calib_9x6/left01.jpg")),
            _ => ("image.png", data("middlebury2005_reindeer_half/disp1.png")),
        };
        let path = scratch(name);
        std::fs::write(&path, mutate(&valid, &edits)).unwrap();
        let _ = load_gray(&path);
        let _ = load_unchanged(&path);
        let _ = GroundTruth::load(&path, 4.0);
    }

    #[test]
    fn mutated_pfm_disparities_load_or_are_refused(
        edits in prop::collection::vec((any::<u8>(), any::<usize>(), any::<u8>()), 1..6),
    ) {
        let path = scratch("valid.pfm");
        let map = DisparityMap { width: 5, height: 3, values: (0..15).map(|v| v as f32).collect() };
        write_disparity(&map, &path).unwrap();
        let valid = std::fs::read(&path).unwrap();
        let path = scratch("mutated.pfm");
        std::fs::write(&path, mutate(&valid, &edits)).unwrap();
        if let Ok(read) = read_pfm(&path) {
            prop_assert_eq!(read.values.len(), read.width * read.height);
        }
    }
}

#[test]
fn a_pfm_whose_size_overflows_is_refused() {
    let path = scratch("overflow.pfm");
    std::fs::write(&path, b"Pf\n4294967296 4294967297\n-1\n\0\0\0\0").unwrap();
    assert!(read_pfm(&path).is_err());
}
