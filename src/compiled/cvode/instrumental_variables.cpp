// The compiled library: the definitions of <sid/cvode/instrumental_variables.hpp>, compiled once.
#include <sid/cvode/instrumental_variables-inl.hpp>
