// The compiled library: the definitions of <sid/cvode/diagnose.hpp>, compiled once.
#include <sid/cvode/diagnose-inl.hpp>
