//! The wire protocol of the solver service (payload types, byte layout, service names and limits).
//! Filled in with the service (issue 3); empty until then.
