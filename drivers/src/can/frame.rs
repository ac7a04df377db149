//! What a CAN adapter delivers: classic data frames with standard identifiers, and bus
//! conditions (bus-off, error-passive, ...) — independent of any adapter's own types so the
//! driver and the codec are tested without a CAN socket.

/// A classic CAN data frame with an 11-bit identifier.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct DataFrame {
    id: u16,
    len: u8,
    data: [u8; 8],
}

impl DataFrame {
    /// `None` if the id needs more than 11 bits or there are more than 8 bytes.
    pub fn new(id: u16, bytes: &[u8]) -> Option<Self> {
        if id > 0x7FF || bytes.len() > 8 {
            return None;
        }
        let mut data = [0u8; 8];
        data[..bytes.len()].copy_from_slice(bytes);
        Some(Self {
            id,
            len: bytes.len() as u8,
            data,
        })
    }

    pub fn id(&self) -> u16 {
        self.id
    }

    pub fn data(&self) -> &[u8] {
        &self.data[..usize::from(self.len)]
    }
}

/// Error states a CAN controller reports. Several may arrive in one error frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct BusCondition {
    /// The controller left the bus (transmit error counter past 255). Fatal.
    pub bus_off: bool,
    /// Error counters past 127: the node may no longer signal errors actively. Fatal.
    pub error_passive: bool,
    /// Error counters past 96.
    pub error_warning: bool,
    /// Back to error-active (counters below 96 again).
    pub back_to_active: bool,
    /// The controller restarted after a bus-off.
    pub restarted: bool,
    /// Anything else reported (lost arbitration, protocol violations, no ACK, overflow).
    pub other: bool,
}

impl BusCondition {
    /// Bus-off and error-passive end motion: the bus can no longer be trusted to carry a
    /// disable in time.
    pub fn is_fatal(&self) -> bool {
        self.bus_off || self.error_passive
    }
}

/// One thing read from the bus.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BusEvent {
    Frame(DataFrame),
    Condition(BusCondition),
    /// A frame this system never uses (remote, extended id, CAN FD): counted, ignored.
    Foreign,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_refuse_what_classic_can_cannot_carry() {
        assert!(DataFrame::new(0x800, &[]).is_none());
        assert!(DataFrame::new(0x123, &[0; 9]).is_none());
        let f = DataFrame::new(0x7FF, &[1, 2, 3]).expect("valid");
        assert_eq!((f.id(), f.data()), (0x7FF, &[1u8, 2, 3][..]));
    }
}
