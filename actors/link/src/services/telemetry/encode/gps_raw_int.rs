//! GPS_RAW_INT: the receiver's own fix, unfiltered (degE7, mm, cm/s, cdeg, accuracies in mm).

use kestrel_proto::geo::deg_e7;
use kestrel_proto::messages::{GpsFix, GpsFixType};
use mavlink::dialects::ardupilotmega::{GPS_RAW_INT_DATA, GpsFixType as MavFix};

/// GPS_RAW_INT from the receiver's fix `g`.
pub fn gps_raw(g: &GpsFix) -> GPS_RAW_INT_DATA {
    let v = g.vel_ned_m_s;
    let speed = v[0].hypot(v[1]);
    GPS_RAW_INT_DATA {
        time_usec: g.time.as_micros(),
        lat: deg_e7(g.lat_deg),
        lon: deg_e7(g.lon_deg),
        alt: (g.alt_msl_m * 1000.0).round() as i32,
        eph: (g.h_acc_m * 100.0).clamp(0.0, 65_534.0) as u16,
        epv: (g.v_acc_m * 100.0).clamp(0.0, 65_534.0) as u16,
        vel: (speed * 100.0).clamp(0.0, 65_534.0) as u16,
        cog: ((v[1].atan2(v[0]).to_degrees().rem_euclid(360.0) * 100.0) as u16) % 36_000,
        fix_type: match g.fix_type {
            GpsFixType::NoFix => MavFix::GPS_FIX_TYPE_NO_FIX,
            GpsFixType::Fix2d => MavFix::GPS_FIX_TYPE_2D_FIX,
            GpsFixType::Fix3d => MavFix::GPS_FIX_TYPE_3D_FIX,
            GpsFixType::Dgps => MavFix::GPS_FIX_TYPE_DGPS,
            GpsFixType::RtkFloat => MavFix::GPS_FIX_TYPE_RTK_FLOAT,
            GpsFixType::RtkFixed => MavFix::GPS_FIX_TYPE_RTK_FIXED,
        },
        satellites_visible: g.satellites,
        h_acc: (g.h_acc_m * 1000.0) as u32,
        v_acc: (g.v_acc_m * 1000.0) as u32,
        vel_acc: (g.s_acc_m_s * 1000.0) as u32,
        ..Default::default()
    }
}

#[cfg(test)]
mod tests {
    use kestrel_proto::Time;

    use super::*;

    #[test]
    fn a_fix_goes_out_in_degrees_e7_millimetres_and_course_over_ground() {
        let g = gps_raw(&GpsFix {
            time: Time::from_micros(5),
            fix_type: GpsFixType::Fix3d,
            satellites: 12,
            lat_deg: 6.7971,
            lon_deg: 79.9017,
            alt_msl_m: 21.5,
            // Flying west at 3 m/s.
            vel_ned_m_s: [0.0, -3.0, 0.0],
            h_acc_m: 0.8,
            v_acc_m: 1.5,
            s_acc_m_s: 0.25,
        });
        assert_eq!((g.lat, g.lon, g.alt), (67_971_000, 799_017_000, 21_500));
        assert_eq!((g.vel, g.cog), (300, 27_000));
        assert_eq!((g.eph, g.epv, g.h_acc, g.v_acc, g.vel_acc), (80, 150, 800, 1500, 250));
        assert_eq!((g.fix_type, g.satellites_visible, g.time_usec), (MavFix::GPS_FIX_TYPE_3D_FIX, 12, 5));
    }
}
