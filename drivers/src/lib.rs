//! Hardware drivers implementing control's ports: the tactile array over a serial line and
//! the Phantom's joint amplifiers over CAN.
