// The compiled library: the definitions of <sid/chain_consistency.hpp>, compiled once.
#include <sid/chain_consistency-inl.hpp>
