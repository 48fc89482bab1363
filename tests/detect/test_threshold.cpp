#include <stdexcept>

#include <gtest/gtest.h>

#include <detect/threshold.h>

using lensfx::detect::Threshold;

TEST(Threshold, ParsesAbsoluteAndRelative) {
    EXPECT_EQ(Threshold::parse("20"), (Threshold{Threshold::Kind::Absolute, 20.0}));
    EXPECT_EQ(Threshold::parse("2.5e3"), (Threshold{Threshold::Kind::Absolute, 2500.0}));
    EXPECT_EQ(Threshold::parse("+6ev"), (Threshold{Threshold::Kind::RelativeEv, 6.0}));
    EXPECT_EQ(Threshold::parse("6EV"), (Threshold{Threshold::Kind::RelativeEv, 6.0}));
    EXPECT_EQ(Threshold::parse("-1.5ev"), (Threshold{Threshold::Kind::RelativeEv, -1.5}));
    EXPECT_EQ(Threshold::parse(" +4 ev "), (Threshold{Threshold::Kind::RelativeEv, 4.0}));
}

TEST(Threshold, RejectsNonsenseNamingTheText) {
    for (const char* bad : {"", "ev", "abc", "-3", "0", "nan", "inf", "6 stops", "1e999", "+6evx", "1e-310", "1e-39", "1e39", "+65ev", "-100ev"}) {
        try {
            (void)Threshold::parse(bad);
            ADD_FAILURE() << "accepted '" << bad << "'";
        } catch (const std::invalid_argument& e) {
            EXPECT_NE(std::string(e.what()).find(std::string("'") + bad + "'"), std::string::npos) << e.what();
        }
    }
}

TEST(Threshold, ResolvesAgainstTheMedianWithAFloor) {
    EXPECT_DOUBLE_EQ(Threshold::parse("20").resolve(0.5, 1.0), 20.0);
    EXPECT_DOUBLE_EQ(Threshold::parse("+6ev").resolve(0.5, 1.0), 32.0);
    EXPECT_DOUBLE_EQ(Threshold::parse("+6ev").resolve(0.001, 1.0), 1.0);  // black frame: the floor
    EXPECT_DOUBLE_EQ(Threshold::parse("+6ev").resolve(0.0, 2.0), 2.0);
}

TEST(Threshold, RoundTripsThroughText) {
    for (const char* t : {"20", "0.75", "+6ev", "-2.5ev"}) EXPECT_EQ(Threshold::parse(Threshold::parse(t).to_string()), Threshold::parse(t)) << t;
}
