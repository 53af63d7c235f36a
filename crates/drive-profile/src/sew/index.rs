//! The indices of the MOVIDRIVE parameters that drivebus uses by name (serial communication
//! manual ch. 7.2): the simulated drive, the masters (P070 to probe a drive) and drivectl (backup
//! exclusions, scan). Every constant is checked against the generated table in a test.

/// P000 speed, 0.001 1/min.
pub const SPEED: u16 = 8318;
/// P002 frequency, 0.001 Hz.
pub const FREQUENCY: u16 = 8319;
/// P003 actual position, increments (4096 per motor revolution).
pub const POSITION: u16 = 8320;
/// P004 output current, 0.001 % of the unit rated current.
pub const OUTPUT_CURRENT_PERCENT: u16 = 8321;
/// P005 active current, 0.001 % of the unit rated current.
pub const ACTIVE_CURRENT_PERCENT: u16 = 8322;
/// P008 DC link voltage, 0.001 V.
pub const DC_LINK_VOLTAGE: u16 = 8325;
/// P009 output current, 0.001 A.
pub const OUTPUT_CURRENT_AMPERE: u16 = 8326;
/// P010–P013 drive status / operating state / fault status / active parameter set (one
/// index; the low word is coded like status word 1).
pub const DRIVE_STATUS: u16 = 8310;
/// P070 unit type.
pub const UNIT_TYPE: u16 = 8301;
/// P071 unit rated current, 0.001 A.
pub const RATED_CURRENT: u16 = 8361;
/// P076 firmware of the basic unit.
pub const FIRMWARE: u16 = 8300;
/// P080 fault t-0 (P081–P084 follow at 8367–8370).
pub const FAULT_T0: u16 = 8366;
/// P100 setpoint source.
pub const SETPOINT_SOURCE: u16 = 8461;
/// P101 control signal source.
pub const CONTROL_SOURCE: u16 = 8462;
/// P130 ramp t11 up CW, ms per 3000 1/min.
pub const RAMP_T11_UP_CW: u16 = 8470;
/// P131 ramp t11 down CW.
pub const RAMP_T11_DOWN_CW: u16 = 8471;
/// P132 ramp t11 up CCW.
pub const RAMP_T11_UP_CCW: u16 = 8472;
/// P133 ramp t11 down CCW.
pub const RAMP_T11_DOWN_CCW: u16 = 8473;
/// P134 ramp t12 up = down (integrator 2).
pub const RAMP_T12: u16 = 8474;
/// P136 stop ramp t13 (rapid stop).
pub const STOP_RAMP_T13: u16 = 8476;
/// P137 emergency ramp t14.
pub const EMERGENCY_RAMP_T14: u16 = 8477;
/// P140 ramp t21 up CW (parameter set 2; P141–P144 follow, P146 t23 at 8484, P147 t24 at
/// 8485).
pub const RAMP_T21_UP_CW: u16 = 8478;
/// P302 maximum speed 1, 0.001 1/min.
pub const MAX_SPEED_1: u16 = 8517;
/// P312 maximum speed 2, 0.001 1/min.
pub const MAX_SPEED_2: u16 = 8521;
/// P620 binary output DO01 function.
pub const DO01: u16 = 8350;
/// P621 binary output DO02 function.
pub const DO02: u16 = 8351;
/// P802 factory setting.
pub const FACTORY_SETTING: u16 = 8594;
/// P803 parameter lock.
pub const PARAMETER_LOCK: u16 = 8595;
/// P804 reset statistics data.
pub const RESET_STATISTICS: u16 = 8596;
/// P810 RS-485 address.
pub const RS485_ADDRESS: u16 = 8597;
/// P811 RS-485 group address.
pub const RS485_GROUP_ADDRESS: u16 = 8598;
/// P812 RS-485 timeout time, ms.
pub const RS485_TIMEOUT: u16 = 8599;
/// P833 reaction to RS-485 timeout.
pub const RS485_TIMEOUT_REACTION: u16 = 8612;
/// P852 user unit, first index.
pub const USER_UNIT: u16 = 8772;
/// P852 user unit, second index.
pub const USER_UNIT_2: u16 = 8773;
/// P870 setpoint description PO1 (PO2, PO3: 8305, 8306).
pub const PO1_DESCRIPTION: u16 = 8304;
/// P873 actual value description PI1 (PI2, PI3: 8308, 8309).
pub const PI1_DESCRIPTION: u16 = 8307;
/// P876 PO data enable.
pub const PO_DATA_ENABLE: u16 = 8622;
/// P813 SBus address.
pub const SBUS_ADDRESS: u16 = 8600;
/// P814 SBus group address.
pub const SBUS_GROUP_ADDRESS: u16 = 8601;
/// P815 SBus timeout time, ms.
pub const SBUS_TIMEOUT: u16 = 8602;
/// P816 SBus baud rate.
pub const SBUS_BAUD_RATE: u16 = 8603;
/// P817 SBus synchronisation ID.
pub const SBUS_SYNC_ID: u16 = 8604;
/// P836 reaction to SBus timeout.
pub const SBUS_TIMEOUT_REACTION: u16 = 8615;
/// P840 manual reset.
pub const MANUAL_RESET: u16 = 8617;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_index_is_the_menu_number_it_names() {
        let named = [
            (SPEED, 0),
            (FREQUENCY, 2),
            (POSITION, 3),
            (OUTPUT_CURRENT_PERCENT, 4),
            (ACTIVE_CURRENT_PERCENT, 5),
            (DC_LINK_VOLTAGE, 8),
            (OUTPUT_CURRENT_AMPERE, 9),
            (DRIVE_STATUS, 10),
            (UNIT_TYPE, 70),
            (RATED_CURRENT, 71),
            (FIRMWARE, 76),
            (FAULT_T0, 80),
            (SETPOINT_SOURCE, 100),
            (CONTROL_SOURCE, 101),
            (RAMP_T11_UP_CW, 130),
            (RAMP_T11_DOWN_CW, 131),
            (RAMP_T11_UP_CCW, 132),
            (RAMP_T11_DOWN_CCW, 133),
            (RAMP_T12, 134),
            (STOP_RAMP_T13, 136),
            (EMERGENCY_RAMP_T14, 137),
            (RAMP_T21_UP_CW, 140),
            (MAX_SPEED_1, 302),
            (MAX_SPEED_2, 312),
            (DO01, 620),
            (DO02, 621),
            (FACTORY_SETTING, 802),
            (PARAMETER_LOCK, 803),
            (RESET_STATISTICS, 804),
            (RS485_ADDRESS, 810),
            (RS485_GROUP_ADDRESS, 811),
            (RS485_TIMEOUT, 812),
            (RS485_TIMEOUT_REACTION, 833),
            (USER_UNIT, 852),
            (PO1_DESCRIPTION, 870),
            (PI1_DESCRIPTION, 873),
            (PO_DATA_ENABLE, 876),
            (SBUS_ADDRESS, 813),
            (SBUS_GROUP_ADDRESS, 814),
            (SBUS_TIMEOUT, 815),
            (SBUS_BAUD_RATE, 816),
            (SBUS_SYNC_ID, 817),
            (SBUS_TIMEOUT_REACTION, 836),
            (MANUAL_RESET, 840),
        ];
        for (index, menu) in named {
            let row = crate::sew::by_number(menu);
            assert_eq!(row.map(|p| p.index), Some(index), "P{menu:03}");
        }
        // Second indices and fault-memory rows.
        assert_eq!(
            crate::sew::by_number(852).and_then(|p| p.index2),
            Some(USER_UNIT_2)
        );
        assert_eq!(crate::sew::by_number(80).map(|p| p.index), Some(FAULT_T0));
        assert_eq!(
            crate::sew::by_number(140).map(|p| p.index),
            Some(RAMP_T21_UP_CW)
        );
    }
}
