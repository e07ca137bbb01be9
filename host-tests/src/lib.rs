//! Host-side scenario helpers around the `beamest` core: simulated rigs,
//! measurement noise and convergence metrics used by the integration tests,
//! the benchmarks and `beamctl`.
