// The compiled library: the definitions of <sid/cvode/free_simulation.hpp>, compiled once.
#include <sid/cvode/free_simulation-inl.hpp>
