//! Support for the end-to-end tests (spawning the service with a unique prefix, goldens).
//! Filled in with the service (issue 3); empty until then.
