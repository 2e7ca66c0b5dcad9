// The compiled library: the definitions of <sid/identify_runs.hpp>, compiled once.
#include <sid/identify_runs-inl.hpp>
