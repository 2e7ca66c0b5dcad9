// The compiled library: the definitions of <sid/identify_chain.hpp> and <sid/diagnose_chain.hpp>,
// compiled once.
#include <sid/identify_chain-inl.hpp>
// The chain diagnosis shares identify_chain's equation builders: compiled in the same unit.
#include <sid/diagnose_chain-inl.hpp>
// The delay search too.
#include <sid/torque_delay-inl.hpp>
// The windows over time are identify_chain runs.
#include <sid/identify_windows-inl.hpp>
