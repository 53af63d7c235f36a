//! Protocol tests of the movilink crate (one test binary).

mod bus;
mod faults;
mod master_slave;
mod props;
mod receiver;
mod timing;
mod vectors;
