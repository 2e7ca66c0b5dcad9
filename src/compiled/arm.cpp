// The compiled library: the definitions of <sid/arm.hpp>, compiled once.
#include <sid/arm-inl.hpp>
