//! The physical plant of one actuator: rotor + gearbox + load, friction, torque constant, a
//! first-order current response limited by the supply and the back-EMF, a gravity link,
//! winding temperature and supply sag.
//!
//! The plant is integrated with a fixed substep of [`SUBSTEP`] (50 µs, i.e. 20 kHz: the rate
//! at which FOC drives of this class typically run their current loop; the simulated firmware
//! runs all its loops at this rate too). Per substep, in this order:
//!
//! 1. current: `i += (i_target - i) * (1 - exp(-dt / tau))` (exact for a first-order lag), where
//!    `i_target` is the drive's reference clamped to `±max_current_a` and to what the bus voltage
//!    can push against the back-EMF, `(±V_bus - Ke w) / R`; with the output disabled the target
//!    is 0 (bridge off; the diode rectification of a back-EMF above the bus voltage is not
//!    modelled);
//! 2. mechanics (motor side): `J dw/dt = Kt i + tau_gravity / N - b w - tau_c sign(w)`, with
//!    `J = J_rotor + J_output / N²`; at rest the rotor stays put while the driving torque does
//!    not exceed the Coulomb friction (stiction), and a speed that would cross zero under
//!    friction stops at zero; semi-implicit Euler (speed first, then the angle with the mean
//!    speed of the step);
//! 3. temperature: one thermal node, `C dT/dt = R i² - (T - T_ambient) / R_th`, updated exactly
//!    for the step;
//! 4. supply: `V_bus = V_supply - R_supply * P / V_supply` with `P = R i² + Ke w i` the electrical
//!    power drawn (negative when braking: the bus voltage then rises).

use core::time::Duration;

use crate::error::ConfigError;
use crate::params::{LoadParams, MotorParams};

/// The fixed integration substep of the plant and of the simulated firmware's control loops.
pub const SUBSTEP: Duration = Duration::from_micros(50);
/// [`SUBSTEP`] in nanoseconds.
pub const SUBSTEP_NS: u64 = 50_000;
/// [`SUBSTEP`] in seconds.
pub const SUBSTEP_S: f64 = 50e-6;

/// Below this current (A) a current decaying towards zero is taken as zero.
const CURRENT_EPSILON_A: f64 = 1e-9;

/// The physical state of one actuator. Angles and speeds are motor side.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct PlantState {
    /// Rotor angle, rad (motor side, unbounded: counts whole turns).
    pub motor_angle_rad: f64,
    /// Rotor speed, rad/s (motor side).
    pub motor_speed_rad_s: f64,
    /// Torque current, A.
    pub current_a: f64,
    /// Winding temperature, °C.
    pub winding_temperature_c: f64,
    /// Voltage at the motor's supply terminals, V.
    pub bus_voltage_v: f64,
}

/// What the drive asks of the power stage during one substep.
#[derive(Copy, Clone, Debug, PartialEq)]
pub enum Drive {
    /// Power stage off: the current decays to zero, the rotor is free.
    Disabled,
    /// Closed current loop towards `current_ref_a`, with the loop's first-order time constant.
    Current {
        /// Torque current reference, A.
        current_ref_a: f64,
        /// Time constant of the current loop, s.
        time_constant_s: f64,
    },
}

/// Conditions imposed from outside (fault injection): a sagging supply, an overheated motor.
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub struct Environment {
    /// Replaces the open-circuit supply voltage while set, V.
    pub supply_voltage_override_v: Option<f64>,
    /// Holds the winding temperature at or above this while set, °C.
    pub temperature_floor_c: Option<f64>,
}

/// One actuator's physics.
#[derive(Clone, Debug)]
pub struct Plant {
    params: MotorParams,
    load: LoadParams,
    state: PlantState,
    /// Total inertia seen at the motor, kg·m².
    inertia_kg_m2: f64,
    back_emf_v_per_rad_s: f64,
    /// exp(-dt / (R_th C)).
    thermal_decay: f64,
    /// (time constant, 1 - exp(-dt / time constant)) of the last current step.
    current_gain: (f64, f64),
}

impl Plant {
    /// A plant at rest at output angle `output_angle_rad`, at ambient temperature, with the
    /// supply unloaded.
    pub fn new(
        params: MotorParams,
        load: LoadParams,
        output_angle_rad: f64,
    ) -> Result<Self, ConfigError> {
        params.validate()?;
        load.validate()?;
        if !output_angle_rad.is_finite() {
            return Err(ConfigError::InvalidParameter {
                name: "initial_output_angle",
                value: output_angle_rad,
                expected: "a finite number",
            });
        }
        let inertia_kg_m2 = params.rotor_inertia_kg_m2
            + load.output_inertia_total_kg_m2() / (params.gear_ratio * params.gear_ratio);
        let thermal_decay = (-SUBSTEP_S
            / (params.thermal_resistance_k_per_w * params.thermal_capacitance_j_per_k))
            .exp();
        let state = PlantState {
            motor_angle_rad: output_angle_rad * params.gear_ratio,
            motor_speed_rad_s: 0.0,
            current_a: 0.0,
            winding_temperature_c: params.ambient_temperature_c,
            bus_voltage_v: params.supply_voltage_v,
        };
        Ok(Self {
            back_emf_v_per_rad_s: params.back_emf_v_per_rad_s(),
            params,
            load,
            state,
            inertia_kg_m2,
            thermal_decay,
            current_gain: (f64::NAN, 0.0),
        })
    }

    /// The current state.
    pub fn state(&self) -> &PlantState {
        &self.state
    }

    /// The physical parameters.
    pub fn params(&self) -> &MotorParams {
        &self.params
    }

    /// The load.
    pub fn load(&self) -> &LoadParams {
        &self.load
    }

    /// Total inertia seen at the motor (rotor plus reflected load), kg·m².
    pub fn inertia_kg_m2(&self) -> f64 {
        self.inertia_kg_m2
    }

    /// Output shaft angle, rad.
    pub fn output_angle_rad(&self) -> f64 {
        self.state.motor_angle_rad / self.params.gear_ratio
    }

    /// Electrical angle of the rotor, rad (pole pairs x mechanical angle).
    pub fn electrical_angle_rad(&self) -> f64 {
        f64::from(self.params.pole_pairs) * self.state.motor_angle_rad
    }

    /// External (gravity) torque reflected to the motor, N·m.
    fn external_torque_nm(&self) -> f64 {
        self.load.gravity_torque_nm(self.output_angle_rad()) / self.params.gear_ratio
    }

    /// Advances the plant by one [`SUBSTEP`].
    pub fn step(&mut self, drive: Drive, env: &Environment) {
        let p = &self.params;
        let dt = SUBSTEP_S;
        let s = &mut self.state;

        // 1. Current.
        let emf = self.back_emf_v_per_rad_s * s.motor_speed_rad_s;
        let (target, tau) = match drive {
            Drive::Disabled => (0.0, p.current_time_constant_s),
            Drive::Current {
                current_ref_a,
                time_constant_s,
            } => {
                let v = s.bus_voltage_v.max(0.0);
                let r = p.winding_resistance_ohm;
                let reference = if current_ref_a.is_finite() {
                    current_ref_a.clamp(-p.max_current_a, p.max_current_a)
                } else {
                    0.0
                };
                (
                    reference.clamp((-v - emf) / r, (v - emf) / r),
                    time_constant_s,
                )
            }
        };
        if self.current_gain.0 != tau {
            let gain = if tau.is_finite() && tau > 0.0 {
                1.0 - (-dt / tau).exp()
            } else if tau == 0.0 {
                1.0
            } else {
                0.0
            };
            self.current_gain = (tau, gain);
        }
        s.current_a += (target - s.current_a) * self.current_gain.1;
        if target == 0.0 && s.current_a.abs() < CURRENT_EPSILON_A {
            s.current_a = 0.0;
        }

        // 2. Mechanics, motor side.
        let external = self
            .load
            .gravity_torque_nm(s.motor_angle_rad / p.gear_ratio)
            / p.gear_ratio;
        let driving = p.torque_constant_nm_per_a * s.current_a + external;
        let coulomb = p.coulomb_friction_nm;
        let w = s.motor_speed_rad_s;
        let accel = if w == 0.0 {
            if driving.abs() <= coulomb {
                0.0
            } else {
                (driving - coulomb * driving.signum()) / self.inertia_kg_m2
            }
        } else {
            (driving - p.viscous_friction_nm_per_rad_s * w - coulomb * w.signum())
                / self.inertia_kg_m2
        };
        let mut w_new = w + accel * dt;
        if w != 0.0 && w_new.signum() != w.signum() {
            // Friction cannot reverse the motion: stop at zero; the next step decides whether
            // the driving torque breaks away in the other direction.
            w_new = 0.0;
        }
        s.motor_angle_rad += 0.5 * (w + w_new) * dt;
        s.motor_speed_rad_s = w_new;

        // 3. Temperature.
        let loss = p.winding_resistance_ohm * s.current_a * s.current_a;
        let steady = p.ambient_temperature_c + loss * p.thermal_resistance_k_per_w;
        s.winding_temperature_c = steady + (s.winding_temperature_c - steady) * self.thermal_decay;
        if let Some(floor) = env.temperature_floor_c {
            s.winding_temperature_c = s.winding_temperature_c.max(floor);
        }

        // 4. Supply.
        let supply = env
            .supply_voltage_override_v
            .unwrap_or(p.supply_voltage_v)
            .max(0.0);
        let power = loss + self.back_emf_v_per_rad_s * s.motor_speed_rad_s * s.current_a;
        s.bus_voltage_v = if supply > 0.0 {
            (supply - p.supply_resistance_ohm * power / supply).max(0.0)
        } else {
            0.0
        };
    }

    /// Whether the plant is in a state that `n` disabled substeps would leave mechanically
    /// unchanged: no current, rotor at rest, and the external torque held by stiction.
    pub fn is_quiescent(&self) -> bool {
        self.state.current_a == 0.0
            && self.state.motor_speed_rad_s == 0.0
            && self.external_torque_nm().abs() <= self.params.coulomb_friction_nm
    }

    /// Advances a [quiescent](Self::is_quiescent) plant with its output disabled by `steps`
    /// substeps at once: only the temperature (cooling, in closed form) and the supply change.
    /// Equivalent to `steps` calls of [`step`](Self::step) with [`Drive::Disabled`] and a
    /// constant `env`, up to rounding.
    pub fn rest(&mut self, steps: u64, env: &Environment) {
        if steps == 0 {
            return;
        }
        let p = &self.params;
        let s = &mut self.state;
        let ambient = p.ambient_temperature_c;
        let decay = self.thermal_decay.powf(steps as f64);
        s.winding_temperature_c = ambient + (s.winding_temperature_c - ambient) * decay;
        if let Some(floor) = env.temperature_floor_c {
            s.winding_temperature_c = s.winding_temperature_c.max(floor);
        }
        s.bus_voltage_v = env
            .supply_voltage_override_v
            .unwrap_or(p.supply_voltage_v)
            .max(0.0);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::GravityLink;

    fn drive(amps: f64) -> Drive {
        Drive::Current {
            current_ref_a: amps,
            time_constant_s: 2e-4,
        }
    }

    fn run(plant: &mut Plant, d: Drive, steps: usize) {
        for _ in 0..steps {
            plant.step(d, &Environment::default());
        }
    }

    #[test]
    fn constant_torque_gives_the_expected_acceleration() {
        // No viscous friction, default Coulomb friction 0.04 N·m, no load.
        let params = MotorParams {
            viscous_friction_nm_per_rad_s: 0.0,
            ..MotorParams::default()
        };
        let mut plant = Plant::new(params, LoadParams::default(), 0.0).unwrap();
        // 5 A. After 10 ms (50 current time constants) the current has settled to 5 A.
        run(&mut plant, drive(5.0), 200);
        let s1 = *plant.state();
        assert!((s1.current_a - 5.0).abs() < 1e-9);
        run(&mut plant, drive(5.0), 200);
        let s2 = *plant.state();
        // a = (Kt i - tau_c) / J = (2.09/9 x 5 - 0.04) / 2.6e-4
        //   = (1.161111 - 0.04) / 2.6e-4 = 4311.97 rad/s²; over 10 ms: 43.1197 rad/s.
        let expected = (2.09 / 9.0 * 5.0 - 0.04) / 2.6e-4 * 0.010;
        assert!(((s2.motor_speed_rad_s - s1.motor_speed_rad_s) - 43.1197).abs() < 1e-3);
        assert!(((s2.motor_speed_rad_s - s1.motor_speed_rad_s) - expected).abs() < 1e-9);
        // The angle grows by the mean speed times the time: (w1 + w2) / 2 x 10 ms.
        let travelled = s2.motor_angle_rad - s1.motor_angle_rad;
        let mean = 0.5 * (s1.motor_speed_rad_s + s2.motor_speed_rad_s) * 0.010;
        assert!((travelled - mean).abs() < 1e-9);
    }

    #[test]
    fn an_unpowered_link_falls_under_gravity() {
        // 1 kg at 0.3 m, horizontal at output angle 0 (offset 90°).
        let load = LoadParams {
            output_inertia_kg_m2: 0.0,
            gravity: Some(GravityLink {
                mass_kg: 1.0,
                length_m: 0.3,
                angle_offset_deg: 90.0,
            }),
        };
        let mut plant = Plant::new(MotorParams::default(), load, 0.0).unwrap();
        // Gravity at the output: -m g l = -1 x 9.80665 x 0.3 = -2.941995 N·m, at the motor
        // /9 = -0.326888 N·m. Dry friction opposes the fall: +0.04 N·m. Net -0.286888 N·m.
        // J at the motor = 2.6e-4 + m l² / N² = 2.6e-4 + 0.09 / 81 = 1.371111e-3 kg·m².
        // Motor acceleration: -0.286888 / 1.371111e-3 = -209.23 rad/s²; in 1 ms (the sine
        // barely changes) the speed reaches -0.20923 rad/s (viscous friction: 4e-5 N·m, < 0.1 %).
        run(&mut plant, Drive::Disabled, 20);
        let w = plant.state().motor_speed_rad_s;
        assert!((w + 0.20923).abs() < 0.0005, "speed {w}");
        // After 100 ms it keeps falling: the output angle went negative by about
        // a t² / 2 / N = 209.23 x 0.01 / 2 / 9 = 0.1162 rad (less as friction grows with speed
        // and the sine shrinks: allow 5 %).
        run(&mut plant, Drive::Disabled, 1_980);
        let fallen = -plant.output_angle_rad();
        assert!((fallen - 0.1162).abs() < 0.1162 * 0.05, "fallen {fallen}");
    }

    #[test]
    fn stiction_holds_a_light_link() {
        // 0.1 kg at 0.3 m: 0.294 N·m at the output, 0.0327 N·m at the motor < 0.04 N·m.
        let load = LoadParams {
            output_inertia_kg_m2: 0.0,
            gravity: Some(GravityLink {
                mass_kg: 0.1,
                length_m: 0.3,
                angle_offset_deg: 90.0,
            }),
        };
        let mut plant = Plant::new(MotorParams::default(), load, 0.0).unwrap();
        run(&mut plant, Drive::Disabled, 1_000);
        assert_eq!(plant.state().motor_angle_rad, 0.0);
        assert!(plant.is_quiescent());
    }

    #[test]
    fn temperature_follows_the_first_order_heating_law() {
        // Rotor held by a huge dry friction so that a constant 10 A flows at standstill.
        let params = MotorParams {
            coulomb_friction_nm: 100.0,
            ..MotorParams::default()
        };
        let mut plant = Plant::new(params, LoadParams::default(), 0.0).unwrap();
        // 60 s at 10 A: loss R i² = 0.8 x 100 = 80 W, steady state 25 + 80 x 2 = 185 °C,
        // time constant R_th C = 600 s: T = 185 - 160 exp(-0.1) = 185 - 144.774 = 40.226 °C.
        // (The first 0.2 ms the current rises: a negligible difference.)
        run(&mut plant, drive(10.0), 1_200_000);
        let t = plant.state().winding_temperature_c;
        assert!((t - 40.226).abs() < 0.01, "temperature {t}");
        // Supply sag at standstill: P = 80 W, I = 80 / 48 = 1.6667 A, sag 0.05 x 1.6667:
        // 47.9167 V.
        assert!((plant.state().bus_voltage_v - 47.916_67).abs() < 1e-4);
    }

    #[test]
    fn back_emf_limits_the_speed() {
        // Full current ask, no friction: the speed saturates where the back-EMF eats the bus
        // voltage. Ke = 60 / (2 pi 40) = 0.23873 V·s/rad; no-load speed ~ 48 / 0.23873
        // = 201.06 rad/s (minus the supply sag and the current needed against friction).
        let mut plant = Plant::new(MotorParams::default(), LoadParams::default(), 0.0).unwrap();
        run(&mut plant, drive(30.0), 40_000); // 2 s
        let w = plant.state().motor_speed_rad_s;
        assert!(w > 190.0 && w < 201.1, "speed {w}");
    }

    #[test]
    fn environment_forces_voltage_and_temperature() {
        let mut plant = Plant::new(MotorParams::default(), LoadParams::default(), 0.0).unwrap();
        let env = Environment {
            supply_voltage_override_v: Some(20.0),
            temperature_floor_c: Some(90.0),
        };
        plant.step(Drive::Disabled, &env);
        assert_eq!(plant.state().bus_voltage_v, 20.0);
        assert_eq!(plant.state().winding_temperature_c, 90.0);
        // Back to normal: the voltage recovers at once, the winding cools slowly.
        plant.step(Drive::Disabled, &Environment::default());
        assert_eq!(plant.state().bus_voltage_v, 48.0);
        assert!(plant.state().winding_temperature_c > 89.99);
        // Resting in closed form equals stepping.
        let mut stepped = plant.clone();
        for _ in 0..10_000 {
            stepped.step(Drive::Disabled, &Environment::default());
        }
        plant.rest(10_000, &Environment::default());
        let (a, b) = (
            plant.state().winding_temperature_c,
            stepped.state().winding_temperature_c,
        );
        assert!((a - b).abs() < 1e-9, "{a} vs {b}");
    }
}
