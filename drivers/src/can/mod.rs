//! The Phantom's joint amplifiers on CAN.
