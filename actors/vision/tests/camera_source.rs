//! Frame sources: a folder of image pairs, a pair of video files, and a missing camera.

use std::path::Path;

use kestrel_vision::image::{crop, load_gray};
use kestrel_vision::{FrameSource, SourceParams, VisionError};
use opencv::core::{Mat, MatTraitConst, Size};
use opencv::prelude::*;
use opencv::videoio::{VideoWriter, VideoWriterTrait};

fn data() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data")
}

#[test]
fn image_folder_pairs_by_name_and_repeats_on_request() {
    let params = |repeat| SourceParams::ImageFolder {
        dir: "opencv_stereo_calib_9x6".into(),
        left: "left0?.jpg".into(),
        right: "right0?.jpg".into(),
        repeat,
    };
    let mut once = FrameSource::open(&params(false), &data()).unwrap();
    let mut count = 0;
    while let Some((l, r)) = once.next_pair().unwrap() {
        assert_eq!((l.cols(), l.rows(), r.cols(), l.typ()), (640, 480, 640, opencv::core::CV_8UC1));
        count += 1;
    }
    assert_eq!(count, 9, "left01..left09");
    let mut repeating = FrameSource::open(&params(true), &data()).unwrap();
    assert!((0..20).all(|_| repeating.next_pair().unwrap().is_some()));

    let unmatched =
        SourceParams::ImageFolder { dir: ".".into(), left: "none*".into(), right: "*".into(), repeat: false };
    assert!(matches!(FrameSource::open(&unmatched, &data()), Err(VisionError::Params(_))));
}

#[test]
fn video_pair_reads_both_files_in_step() {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("vision-video");
    std::fs::create_dir_all(&dir).unwrap();
    // Video codecs want even sizes: 448×374 of the 450×375 image.
    let image =
        crop(&load_gray(&data().join("middlebury2003_cones/im2.png")).unwrap(), 0, 0, 448, 374).unwrap();
    let fourcc = VideoWriter::fourcc('M', 'J', 'P', 'G').unwrap();
    for name in ["left.avi", "right.avi"] {
        let mut writer = VideoWriter::new(dir.join(name), fourcc, 10.0, Size::new(448, 374), false).unwrap();
        assert!(writer.is_opened().unwrap(), "MJPG writer available");
        for _ in 0..3 {
            writer.write(&image).unwrap();
        }
        writer.release().unwrap();
    }
    let params = SourceParams::VideoPair { left: "left.avi".into(), right: "right.avi".into() };
    let mut source = FrameSource::open(&params, &dir).unwrap();
    let mut frames = Vec::<(Mat, Mat)>::new();
    while let Some(pair) = source.next_pair().unwrap() {
        frames.push(pair);
    }
    assert_eq!(frames.len(), 3);
    assert_eq!((frames[0].0.cols(), frames[0].1.rows(), frames[0].0.channels()), (448, 374, 1));

    let missing = SourceParams::VideoPair { left: "nope.avi".into(), right: "right.avi".into() };
    let err = FrameSource::open(&missing, &dir).err().unwrap();
    assert!(err.to_string().contains("nope.avi"), "{err}");
}

#[test]
fn a_missing_camera_is_an_error_not_a_panic() {
    let params = SourceParams::SideBySide { device: 99, width: 1344, height: 376, fps: 30.0 };
    assert!(FrameSource::open(&params, Path::new(".")).is_err());
    let odd = SourceParams::SideBySide { device: 0, width: 1343, height: 376, fps: 30.0 };
    assert!(matches!(FrameSource::open(&odd, Path::new(".")), Err(VisionError::Params(_))));
}
