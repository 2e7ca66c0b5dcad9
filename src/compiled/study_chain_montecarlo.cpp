// The compiled library: the definitions of <sid/study/chain_montecarlo.hpp>, compiled once.
#include <sid/study/chain_montecarlo-inl.hpp>
