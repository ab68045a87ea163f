//! What the simulated firmware says about itself, for judging a controller or a safe stop: since
//! when each motor has applied (and been commanded) no torque.

use crate::common;

use common::*;
use rmd_bus::{CanBus, Clock};
use rmd_protocol::{Dialect, IqControl, MultiTorque, Request};
use rmd_sim::{FaultRule, PhysicalFault, SimConfig};

#[test]
fn safe_since_follows_the_firmware_through_torque_zero_torque_off_and_protection() {
    let (clock, mut bus) = sim_bus(SimConfig::with_motors(2).seed(3));
    let start = clock.now();
    // Powered up: off, safe from the start.
    let snap = bus.snapshot(id(1)).unwrap();
    assert!(!snap.energising);
    assert_eq!(snap.safe_since, Some(start));
    // 1 A on both: energised, not safe.
    bus.send(&MultiTorque::new([IqControl::from_amps(1.0).unwrap().into(); 4]).encode())
        .unwrap();
    clock.sleep_until(clock.now() + ms(2));
    let snap = bus.snapshot(id(2)).unwrap();
    assert!(snap.energising, "{snap:?}");
    assert_eq!(snap.safe_since, None);
    // Zero torque: safe from the instant the frame reached the motor (the firmware applies no
    // current and is commanded none), though still in torque mode.
    let sent = clock.now();
    bus.send(&MultiTorque::new([IqControl::from_amps(0.0).unwrap().into(); 4]).encode())
        .unwrap();
    clock.sleep_until(clock.now() + ms(2));
    let snap = bus.snapshot(id(2)).unwrap();
    assert!(!snap.energising);
    let since = snap.safe_since.unwrap();
    assert!(
        since > sent && since < sent + ms(1),
        "{since:?} vs {sent:?}"
    );
    // Motor off keeps it safe, from the same instant.
    let now = clock.now();
    collect(&mut bus, now);
    ask(&mut bus, 2, Request::MotorOff);
    assert_eq!(bus.snapshot(id(2)).unwrap().safe_since, Some(since));
    // A protection trip (low voltage) makes a driven motor safe by itself.
    let (clock, mut bus) = sim_bus(
        SimConfig::with_motors(1).seed(4).fault(
            FaultRule::new(PhysicalFault::LowVoltage { volts: 30.0 })
                .during(start + ms(5), start + ms(1_000)),
        ),
    );
    bus.send(
        &Dialect::V161
            .encode(
                id(1),
                &Request::Torque {
                    iq_control: IqControl::from_amps(1.0).unwrap().into(),
                },
            )
            .unwrap(),
    )
    .unwrap();
    clock.sleep_until(start + ms(3));
    assert_eq!(bus.snapshot(id(1)).unwrap().safe_since, None);
    clock.sleep_until(start + ms(20));
    let snap = bus.snapshot(id(1)).unwrap();
    assert!(!snap.energising);
    let tripped = snap.safe_since.unwrap();
    assert!(
        tripped >= start + ms(5) && tripped < start + ms(20),
        "{tripped:?}"
    );
}
