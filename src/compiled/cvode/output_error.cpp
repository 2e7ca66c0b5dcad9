// The compiled library: the definitions of <sid/cvode/output_error.hpp>, compiled once.
#include <sid/cvode/output_error-inl.hpp>
