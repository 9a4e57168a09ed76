/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "test_data.h"

#include <pcl_parallel/io/uos.h>

#include <Eigen/Geometry>

#include <filesystem>
#include <fstream>
#include <gtest/gtest.h>

using namespace pcl_parallel::io;

namespace {

/** A file in a fresh temporary directory, removed with the fixture. */
class TempFiles : public ::testing::Test {
protected:
  void
  SetUp() override
  {
    dir_ = std::filesystem::temp_directory_path() /
           ("pcl_parallel_io_" +
            std::to_string(::testing::UnitTest::GetInstance()->random_seed()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::filesystem::create_directories(dir_);
  }
  void
  TearDown() override
  {
    std::filesystem::remove_all(dir_);
  }
  std::string
  write(const std::string& name, const std::string& content)
  {
    const auto p = dir_ / name;
    std::ofstream(p) << content;
    return p.string();
  }
  std::filesystem::path dir_;
};

} // namespace

TEST_F(TempFiles, UosScanSkipsHeaderAndFiltersRange)
{
  const auto path = write("s.3d", "360 x 225\n1 0 0\n\n0 20 0 7\n3276.7 0 0\n0 0 0.05\n");
  const auto all = loadUosScan(path);
  ASSERT_EQ(all->size(), 4u);
  EXPECT_FLOAT_EQ((*all)[1].y, 20.0f);
  const auto filtered = loadUosScan(path, 0.5, 3000.0);
  ASSERT_EQ(filtered->size(), 2u);
  EXPECT_EQ(filtered->width, 2u);
}

TEST_F(TempFiles, MalformedAndTruncatedFilesThrowWithTheLine)
{
  const auto bad = write("bad.3d", "1 2 3\n4 5\n");
  try {
    loadUosScan(bad);
    FAIL() << "no exception";
  }
  catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("bad.3d:2"), std::string::npos) << e.what();
  }
  EXPECT_THROW(loadUosScan(write("nan.3d", "1 2 3\nnan 1 1\n")), std::runtime_error);
  EXPECT_THROW(loadUosPose(write("short.pose", "1 2 3\n4 5\n")), std::runtime_error);
  EXPECT_THROW(loadFramesFinalPose(write("short.frames", "1 0 0 0 0 1 0 0\n")),
               std::runtime_error);
  EXPECT_THROW(loadUosScan((dir_ / "missing.3d").string()), std::runtime_error);
  EXPECT_THROW(loadUosPose(dir_.string()), std::runtime_error); // a directory
}

TEST_F(TempFiles, PoseFollows3dtkEulerConvention)
{
  const auto p = loadUosPose(write("p.pose", "1 2 3\n90 0 0\n"));
  // R = Rx(90°): y -> z
  const Eigen::Vector3d y = p.topLeftCorner<3, 3>() * Eigen::Vector3d::UnitY();
  EXPECT_NEAR(y.z(), 1.0, 1e-12);
  EXPECT_EQ((p.topRightCorner<3, 1>()), Eigen::Vector3d(1, 2, 3));
  const Eigen::Matrix3d r = eulerToRotation3dtk(0.1, 0.2, 0.3);
  const Eigen::Matrix3d expected = (Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitX()) *
                                    Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitY()) *
                                    Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()))
                                       .toRotationMatrix();
  EXPECT_TRUE(r.isApprox(expected, 1e-14));
}

TEST(UosData, OdometryReproducesTheInitialFrameOf3dtk)
{
  PCL_PARALLEL_REQUIRE_DATA(pose, "3dtk_dat/scan002.pose");
  PCL_PARALLEL_REQUIRE_DATA(frames, "3dtk_dat/reference_frames_2009/scan002.frames");
  PCL_PARALLEL_REQUIRE_DATA(scan, "3dtk_dat/scan002.3d");
  // The first .frames line is slam6D's initial (odometry) pose, column-major.
  std::ifstream in(frames);
  Eigen::Matrix4d first;
  for (int i = 0; i < 16; ++i)
    in >> first(i % 4, i / 4);
  EXPECT_TRUE(loadUosPose(pose).isApprox(first, 1e-5)) << loadUosPose(pose) << "\n" << first;
  EXPECT_NEAR(loadFramesFinalPose(frames)(2, 3), 337.79, 0.01); // PROVENANCE.txt
  EXPECT_EQ(loadUosScan(scan)->size(), 81360u);
}
