// The compiled library: the definitions of <sid/identify.hpp>, compiled once.
#include <sid/identify-inl.hpp>
