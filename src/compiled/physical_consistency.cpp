// The compiled library: the definitions of <sid/physical_consistency.hpp>, compiled once.
#include <sid/physical_consistency-inl.hpp>
