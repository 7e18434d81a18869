// readImage/writeImageAtomic (framework/adapters/src/opencv_image.cpp): round trips, and damaged
// files that must be errors naming the file rather than images with made-up pixels.
#include "terramrf/adapters/opencv_image.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "terramrf/errors.hpp"
#include "test_support.hpp"

namespace terramrf {
namespace {
namespace fs = std::filesystem;

/// A 64 × 48 RGB gradient: JPEG keeps it close, PNG exactly.
Image gradient() {
  Image img(64, 48, 3);
  for (int r = 0; r < img.height; ++r)
    for (int c = 0; c < img.width; ++c)
      for (int k = 0; k < 3; ++k)
        img.data[(std::size_t(r) * img.width + c) * 3 + k] = uint8_t(k == 0 ? c * 4 : r * 5);
  return img;
}

std::string bytesOf(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void put(const std::string& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary) << bytes;
}

std::string errorOf(const std::string& path) {
  try {
    readImage(path);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(OpenCvImage, PngAndJpegRoundTrip) {
  test::TempDir d;
  const Image img = gradient();
  writeImageAtomic(d.str() + "/a.png", img);
  const Image png = readImage(d.str() + "/a.png");
  ASSERT_EQ(png.width, 64);
  ASSERT_EQ(png.height, 48);
  EXPECT_EQ(png.data, img.data);
  writeImageAtomic(d.str() + "/a.jpg", img);
  const Image jpg = readImage(d.str() + "/a.jpg");
  ASSERT_EQ(jpg.data.size(), img.data.size());
  int worst = 0;
  for (std::size_t i = 0; i < img.data.size(); ++i)
    worst = std::max(worst, std::abs(int(jpg.data[i]) - int(img.data[i])));
  EXPECT_LE(worst, 40);
  // Bytes after the end-of-image marker (some cameras pad) are not a cut-short file.
  put(d.str() + "/padded.jpg", bytesOf(d.str() + "/a.jpg") + std::string(300, '\0'));
  EXPECT_EQ(readImage(d.str() + "/padded.jpg").data, jpg.data);
}

TEST(OpenCvImage, ACutShortJpegIsAnErrorNotGreyRows) {
  // Found by fuzzing the RELLIS-3D reader: libjpeg decoded half a file, warned "Premature end of
  // JPEG file" without naming it, and the run went on with the lower half grey.
  test::TempDir d;
  writeImageAtomic(d.str() + "/a.jpg", gradient());
  const std::string whole = bytesOf(d.str() + "/a.jpg");
  for (const std::size_t keep : {whole.size() / 2, whole.size() - 2, whole.size() - 1}) {
    const std::string p = d.str() + "/cut.jpg";
    put(p, whole.substr(0, keep));
    const std::string err = errorOf(p);
    EXPECT_NE(err.find(p + ": JPEG cut short"), std::string::npos) << keep << ": " << err;
  }
}

TEST(OpenCvImage, DamagedOrMissingFilesNameTheFile) {
  test::TempDir d;
  writeImageAtomic(d.str() + "/a.png", gradient());
  const std::string whole = bytesOf(d.str() + "/a.png");
  const std::string cut = d.str() + "/cut.png";
  put(cut, whole.substr(0, whole.size() / 2));
  EXPECT_NE(errorOf(cut).find(cut + ": not a readable image"), std::string::npos) << errorOf(cut);
  const std::string empty = d.str() + "/empty.png";
  put(empty, "");
  EXPECT_NE(errorOf(empty).find(empty + ": not a readable image"), std::string::npos);
  const std::string text = d.str() + "/text.jpg";
  put(text, "not an image at all\n");
  EXPECT_NE(errorOf(text).find(text + ": not a readable image"), std::string::npos);
  EXPECT_NE(errorOf(d.str() + "/absent.png").find("absent.png: image file does not exist"),
            std::string::npos);
  const std::string dir = d.str() + "/folder.png";
  fs::create_directory(dir);
  EXPECT_NE(errorOf(dir).find(dir + ":"), std::string::npos) << errorOf(dir);
}

// Features read 8-bit samples: a 16-bit PNG (a depth map, a raw label export) is refused with
// its depth in words, not an OpenCV depth code alone.
TEST(OpenCvImage, SixteenBitImageIsRefusedNamingItsDepth) {
  test::TempDir d;
  const std::string p = d.str() + "/deep.png";
  ASSERT_TRUE(cv::imwrite(p, cv::Mat(4, 6, CV_16UC1, cv::Scalar(1000))));
  const std::string err = errorOf(p);
  EXPECT_NE(err.find(p + ": expected an 8-bit image, got 16-bit unsigned samples"),
            std::string::npos)
      << err;
}

// A PNG with alpha (RGBA, or grey + alpha, which OpenCV expands to four channels) is read as RGB
// without the alpha; nothing else is lost.
TEST(OpenCvImage, AlphaIsDroppedFromFourChannelPngs) {
  test::TempDir d;
  const std::string rgba = d.str() + "/rgba.png";
  cv::Mat m(2, 3, CV_8UC4, cv::Scalar(30, 20, 10, 128));  // B, G, R, A
  m.at<cv::Vec4b>(1, 2) = cv::Vec4b(1, 2, 3, 0);
  ASSERT_TRUE(cv::imwrite(rgba, m));
  const Image img = readImage(rgba);
  ASSERT_EQ(img.channels, 3);
  ASSERT_EQ(img.width, 3);
  ASSERT_EQ(img.height, 2);
  EXPECT_EQ(img.at(0, 0)[0], 10);  // R
  EXPECT_EQ(img.at(0, 0)[2], 30);  // B
  EXPECT_EQ(img.at(2, 1)[0], 3);   // fully transparent: the colour is kept all the same
  EXPECT_EQ(img.at(2, 1)[2], 1);
  // Grey + alpha, 2 x 1 (grey 10, alpha 255; grey 200, alpha 128), written by hand: OpenCV
  // writes no such PNG.
  const std::string ga = d.str() + "/grey_alpha.png";
  put(ga, std::string("\x89PNG\r\n\x1a\n\x00\x00\x00\x0dIHDR\x00\x00\x00\x02\x00\x00\x00\x01"
                      "\x08\x04\x00\x00\x00\x5e\x2b\xb7\x01\x00\x00\x00\x0dIDAT\x78\x9c\x63"
                      "\xe0\xfa\x7f\xa2\x01\x00\x05\x3a\x02\x52\xf1\xb0\xca\x32\x00\x00\x00"
                      "\x00IEND\xae\x42\x60\x82",
                      70));
  const Image g = readImage(ga);
  ASSERT_EQ(g.channels, 3);
  ASSERT_EQ(g.width, 2);
  EXPECT_EQ(g.data, (std::vector<uint8_t>{10, 10, 10, 200, 200, 200}));
}

// No PNG decodes to two channels (OpenCV expands grey + alpha to four), but a PAM with a
// GRAYSCALE_ALPHA tuple does, whatever the file is called: refused with the count found and
// the counts expected.
TEST(OpenCvImage, TwoChannelImageIsRefusedWithItsChannelCount) {
  test::TempDir d;
  const std::string p = d.str() + "/grey_alpha.png";
  put(p, std::string("P7\nWIDTH 2\nHEIGHT 1\nDEPTH 2\nMAXVAL 255\nTUPLTYPE GRAYSCALE_ALPHA\n"
                     "ENDHDR\n\x0a\xff\xc8\x80"));
  const std::string err = errorOf(p);
  EXPECT_NE(err.find(p + ": unsupported channel count 2; expected 1 (grey), 3 (colour) or 4"),
            std::string::npos)
      << err;
}

}  // namespace
}  // namespace terramrf
