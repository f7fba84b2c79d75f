//! Virtual board: models of the ET1100, AD5663 and AD7689 on the host.
