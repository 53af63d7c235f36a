//! The "Examples:" blocks of top-level commands whose definitions live in `main.rs`.

/// Below `drivectl sim --help`.
pub const SIM: &str = "\
Examples:
  drivectl sim movilink --pty --addr 1 --parity none     a drive on a new pty; prints its path
  drivectl sim movilink --pty --addr 1 --addr 2 --parity none    two drives on one bus
  drivectl sim movilink --port /dev/ttyUSB1 --addr 1     answer on a real port (9600 8E1)
  drivectl sim uss --pty --parity none --addr 1           a NORD drive answering USS";

/// Below `drivectl decode --help`.
pub const DECODE: &str = "\
Examples:
  drivectl decode movilink 02 01 85 00 06 20 00 0B B8 13
  drivectl decode movilink 020185000620000BB813 --json
  drivectl decode modbus-rtu 01 03 21 74 00 01 CE 2C
  drivectl decode modbus-ascii :01032174000166
  drivectl decode ctt2 13 2F 08 70 66 02 00 00 00 03 E8
  drivectl decode uss 02 0E 01 70 66 02 00 00 00 03 E8 04 7E 00 00 88";

/// Below `drivectl --help`.
pub const ROOT: &str = "\
Examples:
  drivectl params movidrive --search drehzahl        browse a parameter table
  drivectl ports                                     find the RS-485 adapter
  drivectl movilink --port /dev/ttyUSB0 --addr 1 read P000
  drivectl uss --port /dev/ttyUSB0 --addr 1 read P102 --set 3   a NORD drive over USS
  drivectl ctt2 --sim id                             a NORD drive over CTT2 (simulated AS-i)
  drivectl sim movilink --pty --addr 1 --parity none  a simulated drive to try things on
  drivectl gateway --config plant.toml               every drive of a plant on an MQTT broker
  drivectl completions bash > ~/.local/share/bash-completion/completions/drivectl
Every command's --help has examples of its own.";
