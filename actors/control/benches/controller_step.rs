//! One control-loop iteration (position → attitude on SO(3) → rate → mixer) beside a naive
//! version of the same cascade: Euler-angle attitude error and a mixer that builds and
//! pseudo-inverts the effectiveness matrix on the heap every step.
//!
//! The same iteration on a quad that lost motor 1, which flies the spinning descent
//! (`SpinDescent`) instead of the attitude, rate and mixer stages: beside the healthy step.
//!
//! Also the mixer's slowest path: around a failed hexa motor, with a demand so large that roll
//! and pitch must be scaled (each scale tried searches the yaw torque that fits best).
//!
//! `cargo bench -p kestrel-control --bench controller_step`

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use kestrel_control::{
    AirframeParams, ControlParams, FlightController, Mixer, PositionController, PositionGains,
};
use kestrel_proto::Time;
use kestrel_proto::frame_layout::FrameLayout;
use kestrel_proto::messages::{NavState, Setpoint, SetpointTarget, TrajectorySetpoint};
use nalgebra::{DMatrix, DVector, Vector3};

fn nav(i: u64) -> NavState {
    NavState::exact(
        Time::from_micros(i * 2500),
        [0.995, 0.05, -0.03, 0.08],
        [0.1, -0.2, 0.05],
        [1.0, 0.5, -0.2],
        [3.0, -2.0, -10.0],
    )
}

fn target() -> TrajectorySetpoint {
    TrajectorySetpoint {
        position_ned_m: [Some(10.0), Some(0.0), Some(-12.0)],
        yaw_rad: Some(0.5),
        ..TrajectorySetpoint::default()
    }
}

/// The naive cascade: same position loop, Euler-angle P attitude, P rate loop, heap mixer.
fn naive_step(pos: &mut PositionController, n: &NavState) -> [f64; 4] {
    let Ok(q) = kestrel_proto::attitude::unit_quaternion(n.attitude) else { return [0.0; 4] };
    let out = pos.update(
        &target(),
        &Vector3::from(n.position_ned_m),
        &Vector3::from(n.velocity_ned_m_s),
        0.0,
        0.0025,
    );
    let (r, p, yw) = q.euler_angles();
    let (rd, pd, yd) = out.attitude.euler_angles();
    let rates = Vector3::new(6.5 * (rd - r), 6.5 * (pd - p), 2.8 * (yd - yw));
    let torque =
        (rates - Vector3::from(n.angular_velocity_rad_s)).component_mul(&Vector3::new(0.52, 0.52, 0.44));
    let arm = 0.225 * std::f64::consts::FRAC_1_SQRT_2;
    let b = DMatrix::from_row_slice(
        4,
        4,
        &[-arm, arm, arm, -arm, arm, -arm, arm, -arm, 0.016, 0.016, -0.016, -0.016, 1.0, 1.0, 1.0, 1.0],
    ) * 11.0;
    let pinv = b.pseudo_inverse(1e-12).unwrap_or_else(|_| DMatrix::zeros(4, 4));
    let u = pinv * DVector::from_vec(vec![torque.x, torque.y, torque.z, out.thrust * 44.0]);
    [u[0].clamp(0.0, 1.0), u[1].clamp(0.0, 1.0), u[2].clamp(0.0, 1.0), u[3].clamp(0.0, 1.0)]
}

fn bench(c: &mut Criterion) {
    let mut ctl = FlightController::new(ControlParams::default()).expect("valid");
    let sp = Setpoint {
        time: Time::ZERO,
        armed: true,
        target: SetpointTarget::Trajectory(target()),
        landing: false,
        failed_motor: None,
    };
    let mut i = 0u64;
    c.bench_function("flight_controller_step", |b| {
        b.iter(|| {
            i += 1;
            let sp = Setpoint { time: Time::from_micros(i * 2500), ..sp };
            let _ = ctl.set_setpoint(&sp);
            black_box(ctl.update(black_box(&nav(i))))
        })
    });
    let mut lost = FlightController::new(ControlParams::default()).expect("valid");
    c.bench_function("flight_controller_step_quad_motor_lost", |b| {
        b.iter(|| {
            i += 1;
            let sp = Setpoint { time: Time::from_micros(i * 2500), failed_motor: Some(0), ..sp };
            let _ = lost.set_setpoint(&sp);
            black_box(lost.update(black_box(&nav(i))))
        })
    });
    let mut mixer = Mixer::new(&AirframeParams { frame: FrameLayout::HexaX, ..AirframeParams::default() });
    mixer.set_failed_motor(Some(0)).expect("a hexa's motor");
    let saturating = Vector3::new(-8.0, 5.0, 1.0);
    c.bench_function("mix_around_failed_motor_saturated", |b| {
        b.iter(|| black_box(mixer.mix(black_box(&saturating), black_box(20.0))))
    });
    let mut pos = PositionController::new(PositionGains::default(), 0.334);
    c.bench_function("naive_step", |b| b.iter(|| black_box(naive_step(&mut pos, black_box(&nav(1))))));
}

criterion_group!(benches, bench);
criterion_main!(benches);
