// The compiled library: the definitions of <sid/study/montecarlo.hpp>, compiled once.
#include <sid/study/montecarlo-inl.hpp>
