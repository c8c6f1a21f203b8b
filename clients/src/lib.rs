//! Client library of the solver service (connect, hand scripts, recording, rendering).
//! Filled in with the service and the hand controllers (issues 3 and 4); empty until then.
