// The compiled library: the definitions of <sid/diagnose.hpp>, compiled once.
#include <sid/diagnose-inl.hpp>
