// The object that carries calibd_test_pch's precompiled headers (tests/precompiled.hpp), which
// every test program reuses; it defines nothing.
