// The compiled library: the definitions of <sid/diagnose_runs.hpp>, compiled once.
#include <sid/diagnose_runs-inl.hpp>
