//! Physical parameters of one simulated actuator (motor, gearbox, load, supply), with defaults
//! for an RMD-X8-class motor and where each default comes from.
//!
//! All values are SI units (N·m, A, V, Ω, kg·m², s, °C) and refer to the motor side of the
//! gearbox unless the name says `output`. The motor's encoder sits on the motor side, so every
//! angle and speed the firmware reports is a motor-side value (one output turn is
//! `gear_ratio` motor turns).
//!
//! # Sources of the defaults
//!
//! `[X8V2]`: the MyActuator RMD-X8 V2 (1:9) product page, <https://www.myactuator.com/product-page/rmd-x8-1-9>,
//! as transcribed in the `myactuator_rmd` driver (github.com/2b-t/myactuator_rmd,
//! `include/myactuator_rmd/actuator_constants.hpp`, class `X8V2`, also rendered on
//! docs.ros.org/en/humble/p/myactuator_rmd): reducer 9:1, rated torque 9 N·m, rated current
//! 4.3 A, torque constant 2.09 N·m/A at the output, speed constant 40 rpm/V, rotor inertia
//! 2600 g·cm², 21 pole pairs, no-load speed 215 rpm, rated speed 170 rpm, rated power 160 W.
//! The V2 motors are the generation that speaks protocol v1.61.
//!
//! `[spec]`: the protocol document (torque current range ±33 A in replies).
//!
//! `[estimate]`: an engineering estimate; the reasoning is given with the value. Manufacturer
//! datasheets do not publish winding resistance, friction, thermal or current-loop figures for
//! these actuators.

use crate::error::ConfigError;

/// Standard gravity, m/s².
pub const STANDARD_GRAVITY: f64 = 9.806_65;

/// Physical parameters of the actuator: motor, gearbox, electrical and thermal behaviour, supply.
///
/// ```
/// use rmd_sim::MotorParams;
/// let p = MotorParams::default();
/// assert_eq!(p.gear_ratio, 9.0);
/// // Output-side torque constant of the datasheet: 2.09 N·m/A.
/// assert!((p.torque_constant_nm_per_a * p.gear_ratio - 2.09).abs() < 1e-12);
/// p.validate().unwrap();
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct MotorParams {
    /// Gearbox reduction (motor turns per output turn). Default 9 `[X8V2]`.
    pub gear_ratio: f64,
    /// Motor-side torque constant, N·m per ampere of torque current (`iq`). Default
    /// 2.09 / 9 = 0.2322 N·m/A `[X8V2]` (datasheet: 2.09 N·m/A at the output).
    pub torque_constant_nm_per_a: f64,
    /// Motor speed constant, rpm per volt of supply: the back-EMF constant is its inverse.
    /// Default 40 rpm/V `[X8V2]`.
    pub speed_constant_rpm_per_v: f64,
    /// Inertia of the rotor (and the gearbox input stage), motor side, kg·m². Default
    /// 2.6e-4 kg·m² (2600 g·cm²) `[X8V2]`.
    pub rotor_inertia_kg_m2: f64,
    /// Winding resistance of the DC-equivalent motor model (terminal resistance), Ω.
    /// Default 0.8 Ω `[estimate]`: gives 15 W copper loss at the rated 4.3 A, about 10 % of the
    /// rated 160 W, typical of this motor size.
    pub winding_resistance_ohm: f64,
    /// Time constant of the closed current (torque) loop at the default `iqPidKp`, s: the
    /// torque current follows its reference as a first-order lag. Default 0.2 ms `[estimate]`
    /// (about 800 Hz current-loop bandwidth, typical of FOC drives of this class).
    pub current_time_constant_s: f64,
    /// Largest torque current the drive can produce, A. Default 33 A `[spec]` (the range of
    /// `iq` in replies).
    pub max_current_a: f64,
    /// Pole pairs of the motor (sets the electrical angle of the phase currents in status 3).
    /// Default 21 `[X8V2]`.
    pub pole_pairs: u8,
    /// Viscous friction, motor side, N·m per rad/s. Default 2e-4 `[estimate]`: with the Coulomb
    /// term this draws about 0.35 A at the no-load speed (1935 rpm at the motor).
    pub viscous_friction_nm_per_rad_s: f64,
    /// Coulomb (dry) friction, motor side, N·m; also the breakaway torque. Default 0.04 N·m
    /// `[estimate]`: 0.36 N·m at the output, a plausible back-drive torque for a 9:1 planetary
    /// actuator.
    pub coulomb_friction_nm: f64,
    /// Thermal resistance winding to ambient, K/W. Default 2 K/W `[estimate]`: the rated current
    /// (15 W loss) settles 30 K above ambient.
    pub thermal_resistance_k_per_w: f64,
    /// Thermal capacitance of the winding node, J/K. Default 300 J/K `[estimate]`: a 10 minute
    /// thermal time constant with the resistance above.
    pub thermal_capacitance_j_per_k: f64,
    /// Ambient (and initial winding) temperature, °C. Default 25 °C.
    pub ambient_temperature_c: f64,
    /// Open-circuit supply voltage, V. Default 48 V `[estimate]`: the no-load speed of 215 rpm
    /// x 9 = 1935 rpm at the motor matches 40 rpm/V x 48 V.
    pub supply_voltage_v: f64,
    /// Source resistance of the supply and its cabling, Ω: the bus voltage sags by this times
    /// the supply current. Default 0.05 Ω `[estimate]`.
    pub supply_resistance_ohm: f64,
    /// Mounting offset of the encoder: the raw encoder reading at rotor angle zero, as a
    /// fraction of a turn (0..1). Default 0.
    pub encoder_mount_offset_turns: f64,
}

impl Default for MotorParams {
    fn default() -> Self {
        Self {
            gear_ratio: 9.0,
            torque_constant_nm_per_a: 2.09 / 9.0,
            speed_constant_rpm_per_v: 40.0,
            rotor_inertia_kg_m2: 2.6e-4,
            winding_resistance_ohm: 0.8,
            current_time_constant_s: 2e-4,
            max_current_a: 33.0,
            pole_pairs: 21,
            viscous_friction_nm_per_rad_s: 2e-4,
            coulomb_friction_nm: 0.04,
            thermal_resistance_k_per_w: 2.0,
            thermal_capacitance_j_per_k: 300.0,
            ambient_temperature_c: 25.0,
            supply_voltage_v: 48.0,
            supply_resistance_ohm: 0.05,
            encoder_mount_offset_turns: 0.0,
        }
    }
}

impl MotorParams {
    /// Back-EMF constant, V per rad/s at the motor (the inverse of the speed constant).
    pub fn back_emf_v_per_rad_s(&self) -> f64 {
        60.0 / (core::f64::consts::TAU * self.speed_constant_rpm_per_v)
    }

    /// Checks every value is finite and physically meaningful; the error names the parameter.
    pub fn validate(&self) -> Result<(), ConfigError> {
        positive("gear_ratio", self.gear_ratio)?;
        positive("torque_constant_nm_per_a", self.torque_constant_nm_per_a)?;
        positive("speed_constant_rpm_per_v", self.speed_constant_rpm_per_v)?;
        positive("rotor_inertia_kg_m2", self.rotor_inertia_kg_m2)?;
        positive("winding_resistance_ohm", self.winding_resistance_ohm)?;
        positive("current_time_constant_s", self.current_time_constant_s)?;
        positive("max_current_a", self.max_current_a)?;
        non_negative(
            "viscous_friction_nm_per_rad_s",
            self.viscous_friction_nm_per_rad_s,
        )?;
        non_negative("coulomb_friction_nm", self.coulomb_friction_nm)?;
        positive(
            "thermal_resistance_k_per_w",
            self.thermal_resistance_k_per_w,
        )?;
        positive(
            "thermal_capacitance_j_per_k",
            self.thermal_capacitance_j_per_k,
        )?;
        finite("ambient_temperature_c", self.ambient_temperature_c)?;
        non_negative("supply_voltage_v", self.supply_voltage_v)?;
        non_negative("supply_resistance_ohm", self.supply_resistance_ohm)?;
        finite(
            "encoder_mount_offset_turns",
            self.encoder_mount_offset_turns,
        )?;
        if self.pole_pairs == 0 {
            return Err(ConfigError::InvalidParameter {
                name: "pole_pairs",
                value: 0.0,
                expected: "at least 1",
            });
        }
        Ok(())
    }
}

/// What the actuator drives: extra inertia at the output and an optional gravity link.
///
/// ```
/// use rmd_sim::{GravityLink, LoadParams};
/// let leg = LoadParams {
///     output_inertia_kg_m2: 0.0,
///     gravity: Some(GravityLink { mass_kg: 1.0, length_m: 0.3, angle_offset_deg: 90.0 }),
/// };
/// leg.validate().unwrap();
/// ```
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LoadParams {
    /// Inertia rigidly attached to the output shaft, kg·m² (output side). Default 0.
    pub output_inertia_kg_m2: f64,
    /// A link under gravity attached to the output (a leg or arm joint). Default none.
    pub gravity: Option<GravityLink>,
}

impl LoadParams {
    /// Checks every value is finite and physically meaningful.
    pub fn validate(&self) -> Result<(), ConfigError> {
        non_negative("output_inertia_kg_m2", self.output_inertia_kg_m2)?;
        if let Some(link) = &self.gravity {
            link.validate()?;
        }
        Ok(())
    }

    /// Total inertia at the output, kg·m²: the attached inertia plus the link as a point mass
    /// (`m l²`).
    pub fn output_inertia_total_kg_m2(&self) -> f64 {
        self.output_inertia_kg_m2
            + self
                .gravity
                .as_ref()
                .map_or(0.0, |g| g.mass_kg * g.length_m * g.length_m)
    }

    /// Torque of gravity on the output shaft at output angle `output_angle_rad`, N·m.
    pub fn gravity_torque_nm(&self, output_angle_rad: f64) -> f64 {
        self.gravity
            .as_ref()
            .map_or(0.0, |g| g.torque_nm(output_angle_rad))
    }
}

/// A rigid link on the output shaft with its mass concentrated at `length_m` from the axis.
///
/// Its angle from hanging straight down is `phi = output angle + angle_offset_deg` (output
/// angle positive in the motor's positive, "clockwise", direction), and gravity pulls it back
/// towards `phi = 0` with a torque `-m g l sin(phi)` at the output. With `angle_offset_deg = 90`
/// the link is horizontal at output angle 0.
#[derive(Clone, Debug, PartialEq)]
pub struct GravityLink {
    /// Mass of the link, kg.
    pub mass_kg: f64,
    /// Distance from the axis to the centre of mass, m.
    pub length_m: f64,
    /// Angle of the link from hanging straight down when the output angle is zero, degrees.
    pub angle_offset_deg: f64,
}

impl GravityLink {
    /// Checks every value is finite and physically meaningful.
    pub fn validate(&self) -> Result<(), ConfigError> {
        non_negative("gravity.mass_kg", self.mass_kg)?;
        non_negative("gravity.length_m", self.length_m)?;
        finite("gravity.angle_offset_deg", self.angle_offset_deg)
    }

    /// Torque of gravity at the output, N·m, at output angle `output_angle_rad`.
    pub fn torque_nm(&self, output_angle_rad: f64) -> f64 {
        let phi = output_angle_rad + self.angle_offset_deg.to_radians();
        -self.mass_kg * STANDARD_GRAVITY * self.length_m * phi.sin()
    }
}

fn finite(name: &'static str, value: f64) -> Result<(), ConfigError> {
    if value.is_finite() {
        Ok(())
    } else {
        Err(ConfigError::InvalidParameter {
            name,
            value,
            expected: "a finite number",
        })
    }
}

fn positive(name: &'static str, value: f64) -> Result<(), ConfigError> {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        Err(ConfigError::InvalidParameter {
            name,
            value,
            expected: "a finite number > 0",
        })
    }
}

pub(crate) fn non_negative(name: &'static str, value: f64) -> Result<(), ConfigError> {
    if value.is_finite() && value >= 0.0 {
        Ok(())
    } else {
        Err(ConfigError::InvalidParameter {
            name,
            value,
            expected: "a finite number >= 0",
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_valid_and_consistent_with_the_datasheet() {
        let p = MotorParams::default();
        p.validate().unwrap();
        // 40 rpm/V x 48 V = 1920 rpm at the motor, 213 rpm at the output: the datasheet's
        // no-load speed is 215 rpm.
        let no_load_output_rpm = p.speed_constant_rpm_per_v * p.supply_voltage_v / p.gear_ratio;
        assert!((no_load_output_rpm - 215.0).abs() < 3.0);
        // For a DC-equivalent motor Kt ~ Ke in SI units: 0.2322 N·m/A vs 0.2387 V·s/rad.
        assert!((p.back_emf_v_per_rad_s() - p.torque_constant_nm_per_a).abs() < 0.01);
    }

    #[test]
    fn invalid_parameters_are_named() {
        let p = MotorParams {
            rotor_inertia_kg_m2: f64::NAN,
            ..MotorParams::default()
        };
        assert!(matches!(
            p.validate(),
            Err(ConfigError::InvalidParameter {
                name: "rotor_inertia_kg_m2",
                ..
            })
        ));
        let l = LoadParams {
            output_inertia_kg_m2: 0.0,
            gravity: Some(GravityLink {
                mass_kg: -1.0,
                length_m: 0.1,
                angle_offset_deg: 0.0,
            }),
        };
        assert!(l.validate().is_err());
    }

    #[test]
    fn gravity_pulls_the_link_down() {
        let link = GravityLink {
            mass_kg: 2.0,
            length_m: 0.5,
            angle_offset_deg: 90.0,
        };
        // Horizontal: full torque m g l = 2 x 9.80665 x 0.5 = 9.80665 N·m, towards phi = 0
        // (negative output direction).
        assert!((link.torque_nm(0.0) + 9.80665).abs() < 1e-9);
        // Hanging straight down (output angle -90°): no torque.
        assert!(link.torque_nm(-core::f64::consts::FRAC_PI_2).abs() < 1e-12);
    }
}
