// The compiled library: the definitions of <sid/model/chain_model.hpp> and
// <sid/model/transmission.hpp>, compiled once.
#include <sid/model/chain_model-inl.hpp>
#include <sid/model/transmission-inl.hpp>
