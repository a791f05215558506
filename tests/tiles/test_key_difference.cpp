// A refused --resume names what differs between the run file's key and this run's.
#include <gtest/gtest.h>

#include <string>

#include "key_difference.hpp"

using pointfair::tiles::detail::key_differences;

TEST(KeyDifference, TheSameKeysDifferInNothing) {
  EXPECT_EQ(key_differences("k=0 tau=1 flow=1", "k=0 tau=1 flow=1"), "");
  EXPECT_EQ(key_differences("", ""), "");
}

TEST(KeyDifference, NamesEachChangedValueInTheRunsOrder) {
  EXPECT_EQ(key_differences("k=0 tau=0.80000000000000004 steps=150 flow=1", "k=0 tau=1 steps=100 flow=1"),
            "tau: 0.8 in the run, 1 now; steps: 150 in the run, 100 now");
}

TEST(KeyDifference, NamesEntriesOnlyOneSideHas) {
  // A run started before an entry existed (named only when on), and one that is off now.
  EXPECT_EQ(key_differences("k=0 placement=normal", "k=0 momentum=0.5 gate=0.90000000000000002"),
            "placement: normal in the run, not set now; momentum: not in the run, 0.5 now; gate: not in the run, "
            "0.9 now");
}

TEST(KeyDifference, AWordWithoutAValueIsANameToo) {
  EXPECT_EQ(key_differences("k=0  legacy ", "k=0"), "legacy:  in the run, not set now");
}
