// The compiled library: the definitions of <sid/cvode/friction_refinement.hpp>, compiled once.
#include <sid/cvode/friction_refinement-inl.hpp>
