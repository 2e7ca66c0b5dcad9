// The compiled library: the definitions of <sid/model/effects.hpp>, compiled once.
#include <sid/model/effects-inl.hpp>
