//! The control loop allocates nothing per iteration: a counting global allocator watches one
//! thread through every kind of setpoint, the loop's failsafes (blind, and on the backup attitude
//! fed IMU, compass and barometer samples) and the lock-free hand-over.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

use kestrel_control::rt::triple_buffer;
use kestrel_control::{ControlParams, FlightController, ImuReading};
use kestrel_proto::Time;
use kestrel_proto::messages::{
    BaroSample, MagSample, NavState, Setpoint, SetpointTarget, TrajectorySetpoint,
};

struct Counting;

thread_local! {
    static ALLOCATIONS: Cell<u64> = const { Cell::new(0) };
}

// SAFETY: forwards to the system allocator unchanged; only counts calls on the current thread.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.with(|a| a.set(a.get() + 1));
        // SAFETY: same contract as the caller's.
        unsafe { System.alloc(layout) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: same contract as the caller's.
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

fn nav(i: u64) -> NavState {
    let phase = i as f64 * 0.01;
    NavState::exact(
        Time::from_micros(i * 2500),
        [phase.cos(), phase.sin(), 0.0, 0.0],
        [0.1, -0.2, 0.05],
        [1.0, 0.5, -0.2],
        [3.0, -2.0, -10.0],
    )
}

#[test]
fn a_loop_iteration_allocates_nothing() {
    let mut ctl = FlightController::new(ControlParams::default()).expect("valid");
    let (mut nav_w, mut nav_r) = triple_buffer(Some(nav(0)));
    let (mut sp_w, mut sp_r) = triple_buffer::<Option<Setpoint>>(None);
    let targets = [
        SetpointTarget::Trajectory(TrajectorySetpoint {
            position_ned_m: [Some(10.0), Some(0.0), Some(-12.0)],
            yaw_rad: None,
            yaw_rate_rad_s: 0.3,
            ..TrajectorySetpoint::default()
        }),
        SetpointTarget::Attitude { attitude: [0.9, 0.3, 0.1, 0.0], yaw_rate_rad_s: 0.1, thrust: 0.4 },
        SetpointTarget::Rates { rates_frd_rad_s: [9.0, 0.0, 0.0], thrust: 0.05 },
        SetpointTarget::Rates { rates_frd_rad_s: [f64::NAN, 0.0, 0.0], thrust: 0.05 },
        SetpointTarget::MotorsOff,
    ];
    let mut run = |from: u64, to: u64| {
        for i in from..to {
            let target = targets[(i / 400) as usize % targets.len()];
            sp_w.write(Some(Setpoint {
                time: Time::from_micros(i * 2500),
                armed: true,
                target,
                landing: false,
                // Every other second a motor has failed: switching the allocation is a copy.
                failed_motor: ((i / 800) % 2 == 1).then_some((i / 1600 % 4) as u8),
            }));
            nav_w.write(Some(nav(i)));
            let time = Time::from_micros(i * 2500);
            let accel = [0.1, -0.2, -9.7];
            ctl.on_imu(&ImuReading {
                time,
                gyro_rad_s: [0.01, 0.0, -0.02],
                accel_m_s2: accel,
                accel_clipped: false,
            });
            ctl.on_mag(&MagSample { time, field_gauss: [0.3, 0.05, -0.1] });
            ctl.on_baro(&BaroSample { time, pressure_pa: 101_000.0, altitude_m: 30.0, temperature_c: 20.0 });
            if let (Some(sp), true) = sp_r.read() {
                let _ = ctl.set_setpoint(sp);
            }
            // Now and then, and for a whole second, the estimator's state is gone: the backup
            // attitude flies (aligned after 2 s), blind before it is.
            let out = match nav_r.read() {
                (Some(n), _) if i % 97 != 0 && !(2000..2400).contains(&i) => ctl.update(n),
                _ if i % 291 == 0 => ctl.fly_blind(time),
                _ => ctl.fly_without_nav(time),
            };
            assert!(out.motors.iter().all(|m| m.is_finite()));
        }
    };
    run(0, 10);
    let before = ALLOCATIONS.with(Cell::get);
    run(10, 4000);
    let allocations = ALLOCATIONS.with(Cell::get) - before;
    println!("allocations in 3990 loop iterations: {allocations}");
    assert_eq!(allocations, 0);
    assert!(ctl.counters().backup_steps >= 400, "the backup flew: {:?}", ctl.counters());
}
