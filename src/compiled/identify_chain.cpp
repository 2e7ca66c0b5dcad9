// The compiled library: the definitions of <sid/identify_chain.hpp>, compiled once.
#include <sid/identify_chain-inl.hpp>
